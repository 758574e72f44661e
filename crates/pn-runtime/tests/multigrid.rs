//! The aggregation multigrid preconditioner (`pn_runtime::solver::multigrid`): symmetry of
//! the V-cycle, resolution-independent iteration counts on CDA, and the same answer as
//! the other parity preconditioners, on systems assembled with the independent quadrature
//! stencil of `common`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod common;

use common::{builtin_problem, opts, rel_diff, system};
use pn_krylov::linalg::{dot, norm};
use pn_runtime::assemble::System;
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::solver::multigrid::smoother::pseudo_random;
use pn_runtime::solver::multigrid::solve::mg_krylov;
use pn_runtime::solver::multigrid::{FineCycle, Geometry, MgOptions};
use pn_runtime::solver::parity::precond::Built;
use pn_runtime::solver::parity::reduced::{ReducedMode, ReducedOperator};
use pn_runtime::solver::parity::split::split;
use pn_runtime::solver::parity::{ParityCg, ParityReport, Precond, SYMMETRY_TOL};
use pn_runtime::solver::pn_layout::even_mask;
use pn_runtime::solver::SolverKind;
use pn_runtime::Layout;
use pn_stencil::Dim;
use sprs::{CsMat, TriMat};

fn checkerboard(res: usize) -> Problem {
    builtin_problem("checkerboard", Dim::Two, &[res])
}

fn pointsource3d(res: usize, bc: Boundary) -> Problem {
    let mut p = builtin_problem("pointsource", Dim::Three, &[res]);
    p.boundary = bc;
    p
}

fn solve(layout: &Layout, sys: &System, precond: Precond, tol: f64) -> (Vec<f64>, ParityReport) {
    let solver = ParityCg::for_layout(layout).with_precond(precond);
    let (u, rep) = solver
        .solve_detailed(&sys.matrix, &sys.rhs, &opts(tol))
        .unwrap();
    assert!(rep.stats.converged(), "{:?}", rep.stats);
    (u, rep)
}

/// Both solutions reach a relative residual of 1e-11; their difference is at most
/// cond(A)·2e-11 relative, and cond(A) ≲ 1e4 on these small grids (CGNR needs ~10³
/// iterations), so 1e-6 has margin while a wrong preconditioned solve would be O(1) off.
const SAME_ANSWER: f64 = 1e-6;

#[test]
fn vcycle_is_symmetric_positive_definite() {
    // Dirichlet closure: S is symmetric (measured below), so M⁻¹ must be too, for the
    // multiplicative V-cycle and for the additive finest level (which the default picks
    // for a symmetric S).
    let problem = pointsource3d(12, Boundary::Dirichlet);
    for (order, fine_cycle) in [
        (1, FineCycle::Multiplicative),
        (3, FineCycle::Multiplicative),
        (1, FineCycle::AdditiveIfSymmetric),
        (3, FineCycle::AdditiveIfSymmetric),
    ] {
        let (layout, sys) = system(&problem, order);
        let sp = split(&sys.matrix, &even_mask(&layout)).unwrap();
        let op = ReducedOperator::new(&sp, ReducedMode::MatrixFree);
        assert!(op.asymmetry(2) < SYMMETRY_TOL);
        let geom = Geometry::from_layout(&layout, None);
        // Small coarse limit so that the cycle has several levels on this grid.
        let mg_opts = MgOptions {
            coarse_max: 50,
            fine_cycle,
            ..MgOptions::default()
        };
        let mg = Built::multigrid(&sp, &geom, &mg_opts).unwrap();
        let Built::Multigrid(h) = &mg else {
            panic!("not a multigrid")
        };
        assert!(h.level_sizes().len() >= 3, "{}", h.describe());
        assert_eq!(
            h.is_additive(),
            fine_cycle == FineCycle::AdditiveIfSymmetric,
            "{}",
            h.describe()
        );
        let apply = |x: &[f64], y: &mut [f64]| op.apply(x, y);
        let n = op.len();
        for seed in 0..3 {
            let x = pseudo_random(n, 10 + seed);
            let y = pseudo_random(n, 20 + seed);
            let (mut mx, mut my) = (vec![0.0; n], vec![0.0; n]);
            mg.apply_with(&apply, &x, &mut mx);
            mg.apply_with(&apply, &y, &mut my);
            // Rounding in two n-term dot products of O(1) values: ~√n·1e-16 relative.
            let asym = (dot(&x, &my) - dot(&y, &mx)).abs() / (norm(&x) * norm(&my));
            assert!(asym < 1e-10, "P{order}: xᵀMy − yᵀMx relative {asym:e}");
            assert!(dot(&x, &mx) > 0.0, "P{order}: xᵀMx ≤ 0");
        }
    }
}

#[test]
fn additive_finest_level_only_where_s_is_symmetric() {
    // The extrapolation (Neumann) closure makes S slightly nonsymmetric from P_3 on
    // (GMRES runs, whose orthogonalisation makes the additive form's extra iterations
    // expensive): the default keeps the multiplicative V-cycle there; P_1 stays symmetric.
    for (order, want_additive) in [(1, true), (3, false)] {
        let (layout, sys) = system(&pointsource3d(8, Boundary::Neumann), order);
        let sp = split(&sys.matrix, &even_mask(&layout)).unwrap();
        let geom = Geometry::from_layout(&layout, None);
        let mg = Built::multigrid(&sp, &geom, &MgOptions::default()).unwrap();
        let Built::Multigrid(h) = &mg else {
            panic!("not a multigrid")
        };
        assert_eq!(h.is_additive(), want_additive, "P{order}: {}", h.describe());
        // The additive form applies S in neither the setup nor the cycle.
        assert_eq!(h.setup_fine_applications() == 0, want_additive);
    }
}

/// The 7-point CDA operator −∇·(D∇φ) + σ_a φ on n³ cells of [0,2]³ (Dirichlet φ = 0
/// outside), σ_t = 8, albedo 0.9 (the point-source medium), D = 1/(3σ_t).
fn cda(n: usize) -> (CsMat<f64>, Vec<f64>, Geometry) {
    let (sigma_t, albedo) = (8.0, 0.9);
    let h = 2.0 / n as f64;
    let d = 1.0 / (3.0 * sigma_t) / (h * h);
    let sigma_a = sigma_t * (1.0 - albedo);
    let idx = |i: usize, j: usize, k: usize| (i * n + j) * n + k;
    let mut tri = TriMat::new((n * n * n, n * n * n));
    let mut geom = Geometry {
        class: Vec::new(),
        coords: Vec::new(),
    };
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let row = idx(i, j, k);
                tri.add_triplet(row, row, sigma_a + 6.0 * d);
                let c = [i as i64, j as i64, k as i64];
                for axis in 0..3 {
                    for s in [-1i64, 1] {
                        let mut q = c;
                        q[axis] += s;
                        if q.iter().all(|&v| (0..n as i64).contains(&v)) {
                            tri.add_triplet(
                                row,
                                idx(q[0] as usize, q[1] as usize, q[2] as usize),
                                -d,
                            );
                        }
                    }
                }
                geom.class.push(0);
                geom.coords.push([i as u32, j as u32, k as u32]);
            }
        }
    }
    let mut b = vec![0.0; n * n * n];
    b[idx(n / 2, n / 2, n / 2)] = 1.0 / (h * h * h);
    (tri.to_csr(), b, geom)
}

#[test]
fn cda_iterations_do_not_grow_with_resolution() {
    let mut its = Vec::new();
    for n in [16, 32, 64] {
        let (a, b, geom) = cda(n);
        let (u, st) = mg_krylov(&a, &b, &geom, &opts(1e-8)).unwrap();
        assert!(st.converged(), "{n}³: {st:?}");
        assert!(u.iter().all(|v| v.is_finite()));
        eprintln!("CDA {n}³: {} MG-CG iterations", st.iterations);
        its.push(st.iterations as f64);
    }
    // Resolution independence: within ±30% of the coarsest grid's count (plain CG's count
    // would double per refinement, as √cond ∝ 1/h).
    for &k in &its[1..] {
        assert!(
            (k - its[0]).abs() <= 0.3 * its[0] + 1.0,
            "iterations {its:?}"
        );
    }
}

#[test]
fn same_answer_as_the_other_preconditioners() {
    // Checkerboard (Neumann: S slightly nonsymmetric → GMRES) and point source (Dirichlet
    // → CG), P_3, against ILU(0) and Jacobi.
    let cases = [
        (checkerboard(35), 3, Precond::Ilu0),
        (pointsource3d(16, Boundary::Dirichlet), 3, Precond::Jacobi),
        // P_1's S is symmetric even with the Neumann closure, so the default multigrid has
        // an additive finest level: 28 / 31 / 32 CG iterations at 16³ / 24³ / 32³ to 1e-11,
        // ILU(0) 23 / 33 / 43 — hence 32³, where multigrid's flat count is clearly ahead.
        (pointsource3d(32, Boundary::Neumann), 1, Precond::Ilu0),
    ];
    for (problem, order, other) in cases {
        let (layout, sys) = system(&problem, order);
        let (um, rm) = solve(&layout, &sys, Precond::Multigrid, 1e-11);
        let (uo, ro) = solve(&layout, &sys, other.clone(), 1e-11);
        let d = rel_diff(&um, &uo);
        eprintln!(
            "P{order} {:?}: mg {} {} it, {} {} {} it, diff {d:.1e}",
            problem.grid.res,
            rm.method.name(),
            rm.stats.iterations,
            other.name(),
            ro.method.name(),
            ro.stats.iterations
        );
        assert_eq!(rm.precond, "mg");
        assert!(d < SAME_ANSWER, "differ by {d:e}");
        assert!(rm.stats.iterations < ro.stats.iterations);
    }
}

#[test]
fn solver_kind_routes() {
    // `parity-mg` through the layout-aware constructor; without a layout it is parity-cg.
    let problem = checkerboard(20);
    let (layout, sys) = system(&problem, 1);
    let s = SolverKind::ParityMg.solver_for(&layout);
    let (u, st) = s.solve(&sys.matrix, &sys.rhs, &opts(1e-10));
    assert!(st.converged() && st.relative_residual <= 1e-10, "{st:?}");
    let (u2, _) = SolverKind::ParityCg
        .solver()
        .solve(&sys.matrix, &sys.rhs, &opts(1e-10));
    assert!(rel_diff(&u, &u2) < SAME_ANSWER);
    assert_eq!(
        "parity-mg".parse::<SolverKind>().unwrap(),
        SolverKind::ParityMg
    );
    // Multigrid without positions is a clear error, not a panic.
    let no_layout = ParityCg::new(even_mask(&layout), Precond::Multigrid);
    assert!(no_layout
        .solve_detailed(&sys.matrix, &sys.rhs, &opts(1e-10))
        .is_err());
}

/// Work against the CGNR baseline, in applications of `A` (CGNR: two per iteration;
/// parity: every application of `S`, including the multigrid smoothing, the setup's power
/// iteration and the symmetry probe, counts as one, see `ParityReport`):
/// `cargo test --release -p pn-runtime --test multigrid -- --ignored --nocapture`.
#[test]
#[ignore]
fn applications_vs_cgnr_table() {
    use pn_runtime::solver::cgnr::Cgnr;
    use pn_runtime::solver::LinearSolver;
    let cases = [
        ("checkerboard 71² P_5", checkerboard(71), 5, 1e-10),
        ("checkerboard 71² P_3", checkerboard(71), 3, 1e-10),
        (
            "pointsource 40³ P_3",
            pointsource3d(40, Boundary::Neumann),
            3,
            1e-6,
        ),
        (
            "pointsource 40³ P_1",
            pointsource3d(40, Boundary::Neumann),
            1,
            1e-6,
        ),
    ];
    for (name, problem, order, tol) in cases {
        let (layout, sys) = system(&problem, order);
        let (uc, sc) = Cgnr.solve(&sys.matrix, &sys.rhs, &opts(tol));
        assert!(sc.converged());
        for pre in [Precond::Multigrid, Precond::Auto] {
            let solver = ParityCg::new(even_mask(&layout), pre.clone());
            let solver = if pre == Precond::Multigrid {
                solver.with_layout_geometry(&layout)
            } else {
                solver
            };
            let (u, rep) = solver
                .solve_detailed(&sys.matrix, &sys.rhs, &opts(tol))
                .unwrap();
            let apps = rep.a_equivalent_applications();
            eprintln!(
                "{name}: cgnr {} it = {} A; {} ({}) {} it = {apps} A-equivalent; ratio {:.1}×; diff {:.1e}",
                sc.iterations,
                2 * sc.iterations,
                rep.precond,
                rep.method.name(),
                rep.stats.iterations,
                (2 * sc.iterations) as f64 / apps as f64,
                rel_diff(&u, &uc)
            );
        }
    }
}

/// The statistics name the Krylov method that ran: CG on the symmetric CDA matrix,
/// BiCGSTAB once a drift term makes it measurably nonsymmetric (both still converge).
#[test]
fn the_reported_solver_names_the_krylov_method_that_ran() {
    let (a, b, geom) = cda(16);
    let (_, st) = mg_krylov(&a, &b, &geom, &opts(1e-8)).unwrap();
    assert_eq!(st.solver, "mg-cg");
    // A first-order drift along the storage order: +c above the diagonal, −c below.
    let mut tri = sprs::TriMat::new((a.rows(), a.cols()));
    for (v, (i, j)) in a.iter() {
        let drift = if i < j {
            0.2 * v.abs()
        } else if i > j {
            -0.2 * v.abs()
        } else {
            0.0
        };
        tri.add_triplet(i, j, *v + drift);
    }
    let nonsymmetric: sprs::CsMat<f64> = tri.to_csr();
    let (u, st) = mg_krylov(&nonsymmetric, &b, &geom, &opts(1e-8)).unwrap();
    assert_eq!(st.solver, "mg-bicgstab");
    assert!(st.converged() && u.iter().all(|v| v.is_finite()), "{st:?}");
}

/// Solves `sys` to 1e-10 with the default multigrid and with `variant`, and checks that the
/// variant changes the preconditioner by rounding only: both converge, in the same
/// iterations up to one, to the same answer.
fn same_solve_as_the_default(layout: &Layout, sys: &System, order: i32, variant: MgOptions) {
    let solver = ParityCg::for_layout(layout).with_precond(Precond::Multigrid);
    let mut o = opts(1e-10);
    let (u_default, default) = solver.solve_detailed(&sys.matrix, &sys.rhs, &o).unwrap();
    o.tuning.multigrid = Some(variant);
    let (u_variant, variant) = solver.solve_detailed(&sys.matrix, &sys.rhs, &o).unwrap();
    assert!(default.stats.converged() && variant.stats.converged());
    assert!(
        default.stats.iterations.abs_diff(variant.stats.iterations) <= 1,
        "P_{order}: {} vs {} iterations",
        default.stats.iterations,
        variant.stats.iterations
    );
    assert!(rel_diff(&u_default, &u_variant) <= SAME_ANSWER);
}

/// The coarse levels in single precision (the default) against double: the preconditioner
/// changes by rounding only, so the solve takes the same iterations (up to one) to the same
/// tolerance, with the same answer.
#[test]
fn single_precision_coarse_levels_change_nothing_but_rounding() {
    for (problem, order) in [
        (pointsource3d(16, Boundary::Neumann), 3),
        (checkerboard(31), 5),
    ] {
        let (layout, sys) = system(&problem, order);
        let double = MgOptions {
            double_coarse: true,
            ..MgOptions::default()
        };
        same_solve_as_the_default(&layout, &sys, order, double);
    }
}

/// The structured coarse levels stored as per-class stencils with per-row weights (the
/// default) against the compact CSR: the same `f32` entries summed in another order, so the
/// solve takes the same iterations (up to one) to the same answer; and the hierarchy of the
/// 3D point source and the 2D checkerboard does store its coarse levels as stencils.
#[test]
fn stencil_coarse_levels_change_nothing_but_rounding() {
    for (problem, order) in [
        (pointsource3d(16, Boundary::Neumann), 3),
        (pointsource3d(12, Boundary::Dirichlet), 5),
        (checkerboard(31), 5),
    ] {
        let (layout, sys) = system(&problem, order);
        let csr = MgOptions {
            stencil_coarse: false,
            ..MgOptions::default()
        };
        same_solve_as_the_default(&layout, &sys, order, csr);
        // The hierarchies themselves: the coarse levels are stencils by default (at least
        // the first; the smallest ones, mostly boundary rows, may pad too much and stay
        // CSR), none without.
        let mask = pn_runtime::solver::pn_layout::retained_mask(
            &layout,
            pn_runtime::solver::pn_layout::Retained::for_layout(&layout),
        );
        let sp = split(&sys.matrix, &mask).unwrap();
        let geometry = Geometry::from_layout(&layout, None);
        for stencil_coarse in [true, false] {
            let mg_opts = MgOptions {
                stencil_coarse,
                coarse_max: 50,
                ..MgOptions::default()
            };
            let Built::Multigrid(mg) = Built::multigrid(&sp, &geometry, &mg_opts).unwrap() else {
                panic!("not a multigrid")
            };
            let coarse = mg.level_sizes().len() - 2;
            assert!(coarse >= 1, "{}", mg.describe());
            let stencils = mg.stencil_levels();
            let ok = if stencil_coarse {
                (1..=coarse).contains(&stencils)
            } else {
                stencils == 0
            };
            assert!(ok, "P_{order}: {}", mg.describe());
        }
    }
}

/// The finest level of the cycle in single precision (the default for tolerances of 1e-6 and
/// looser) against double: the solve reaches the same tolerance in the true `f64` residual,
/// in about the same number of iterations, and the answers agree to the tolerance's order
/// (both are within 1e-6 of the solution in the residual; cond ≲ 1e4 here, see
/// `SAME_ANSWER`, so 1e-6 · 1e4 bounds their difference). The single-precision products
/// are counted among the applications of `S`.
#[test]
fn single_precision_finest_level_meets_the_tolerance() {
    for (problem, order) in [
        (pointsource3d(16, Boundary::Neumann), 3),
        (pointsource3d(16, Boundary::Dirichlet), 5),
        (checkerboard(31), 5),
    ] {
        let (layout, sys) = system(&problem, order);
        let solver = ParityCg::for_layout(&layout).with_precond(Precond::Multigrid);
        let mut o = opts(1e-6);
        let run = |single: bool, o: &mut pn_runtime::solver::SolverOptions| {
            o.tuning.multigrid = Some(MgOptions {
                single_fine: Some(single),
                ..MgOptions::default()
            });
            solver.solve_detailed(&sys.matrix, &sys.rhs, o).unwrap()
        };
        let (u_single, single) = run(true, &mut o);
        let (u_double, double) = run(false, &mut o);
        for rep in [&single, &double] {
            assert!(rep.stats.converged(), "P_{order}: {:?}", rep.stats);
            assert!(rep.stats.relative_residual <= 1e-6, "P_{order}");
        }
        assert!(
            single.stats.iterations.abs_diff(double.stats.iterations) <= 2,
            "P_{order}: {} vs {} iterations",
            single.stats.iterations,
            double.stats.iterations
        );
        assert!(
            single.reduced_applications + 2 >= double.reduced_applications,
            "P_{order}: {} vs {} applications",
            single.reduced_applications,
            double.reduced_applications
        );
        let d = rel_diff(&u_single, &u_double);
        assert!(d <= 1e-2, "P_{order}: {d:e}");
    }
    // The hierarchy really runs its finest level in f32 when asked (the stencil S).
    let (layout, sys) = system(&pointsource3d(12, Boundary::Neumann), 3);
    let mask = pn_runtime::solver::pn_layout::retained_mask(
        &layout,
        pn_runtime::solver::pn_layout::Retained::for_layout(&layout),
    );
    let sp = split(&sys.matrix, &mask).unwrap();
    let geometry = Geometry::from_layout(&layout, None);
    let op = ReducedOperator::new(&sp, ReducedMode::MatrixFree).with_stencil(&geometry);
    for single in [true, false] {
        let mg_opts = MgOptions {
            single_fine: Some(single),
            ..MgOptions::default()
        };
        match Built::multigrid_with(&sp, &geometry, &mg_opts, &op).unwrap() {
            Built::Multigrid(mg) => assert_eq!(mg.is_single_fine(), single),
            _ => panic!("not a multigrid"),
        }
    }
}
