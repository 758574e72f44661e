//! Assembly straight into the parity blocks (`assemble_split`) against splitting the
//! assembled matrix, and the parity solve from the blocks alone against the solve with `A`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod common;

use common::{builtin_problem, opts, rel_diff, QuadKernel};
use pn_runtime::assemble::assemble;
use pn_runtime::assemble_split::{assemble_split, assemble_split_retaining, has_parity_structure};
use pn_runtime::field::Field;
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::solver::parity::split::split;
use pn_runtime::solver::parity::{ParityCg, Precond};
use pn_runtime::solver::pn_layout::{even_mask, retained_mask, Retained};
use pn_runtime::Layout;
use pn_stencil::{Dim, StencilKernel};

fn scene(name: &str, dim: Dim, res: usize, boundary: Boundary) -> Problem {
    let mut p = builtin_problem(name, dim, &[res]);
    p.boundary = boundary;
    p
}

/// Checkerboard (heterogeneous, 2D) and point source (3D), both closures, P_1 and P_3.
fn cases() -> Vec<(String, Problem, i32)> {
    let mut out = Vec::new();
    let slab: Boundary = "x=marshak,ymax=dirichlet".parse().unwrap();
    for bc in [
        Boundary::Neumann,
        Boundary::Dirichlet,
        Boundary::Marshak,
        slab,
    ] {
        for order in [1, 3] {
            out.push((
                format!("checkerboard P_{order} {bc:?}"),
                scene("checkerboard", Dim::Two, 21, bc),
                order,
            ));
            out.push((
                format!("pointsource P_{order} {bc:?}"),
                scene("pointsource", Dim::Three, 8, bc),
                order,
            ));
        }
    }
    out
}

/// The blocks are exactly those of `split(assemble(..))`: same entries, same order, same
/// scaling (both divide the raw C entry by the assembled odd diagonal).
#[test]
fn blocks_equal_the_split_of_the_assembled_matrix() {
    for (name, problem, order) in cases() {
        let kernel = QuadKernel::new(order, problem.grid.dim, true);
        let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
        assert!(has_parity_structure(&kernel), "{name}");
        let sys = assemble(&problem, &kernel, &layout).unwrap();
        let reference = split(&sys.matrix, &even_mask(&layout)).unwrap();
        let direct = assemble_split(&problem, &kernel, &layout).unwrap().unwrap();
        let s = &direct.split;
        assert_eq!(s.even, reference.even, "{name}");
        assert_eq!(s.odd, reference.odd, "{name}");
        assert_eq!(s.d_e, reference.d_e, "{name}");
        assert_eq!(s.d_o, reference.d_o, "{name}");
        assert_eq!(s.b, reference.b, "{name}: B");
        assert_eq!(s.c_scaled, reference.c_scaled, "{name}: C̃");
        assert_eq!(s.nnz_a, sys.matrix.nnz(), "{name}");
        assert_eq!(direct.rhs, sys.rhs, "{name}");
        let max = sys.matrix.data().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert_eq!(direct.max_entry, max, "{name}");
    }
}

/// Solving from the blocks gives the answer of the solve with `A`, and its residual
/// (computed from the blocks) is the residual of `A` to rounding.
#[test]
fn solve_from_blocks_matches_solve_with_matrix() {
    for (name, problem, order) in cases() {
        let kernel = QuadKernel::new(order, problem.grid.dim, true);
        let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
        let sys = assemble(&problem, &kernel, &layout).unwrap();
        let direct = assemble_split(&problem, &kernel, &layout).unwrap().unwrap();
        for pre in [Precond::Auto, Precond::Multigrid, Precond::Jacobi] {
            let solver =
                ParityCg::new(even_mask(&layout), pre.clone()).with_layout_geometry(&layout);
            let (u_a, rep_a) = solver
                .solve_detailed(&sys.matrix, &sys.rhs, &opts(1e-9))
                .unwrap();
            let (u_s, rep_s) = solver
                .solve_split(&direct.split, &direct.rhs, &opts(1e-9))
                .unwrap();
            assert!(
                rep_a.stats.converged() && rep_s.stats.converged(),
                "{name} {pre:?}"
            );
            assert_eq!(
                rep_a.stats.iterations, rep_s.stats.iterations,
                "{name} {pre:?}"
            );
            assert!(rel_diff(&u_s, &u_a) < 1e-12, "{name} {pre:?}");
            // The residual of A on the blocks' solution.
            let mut r = vec![0.0; sys.rhs.len()];
            pn_krylov::linalg::residual(&sys.matrix, &u_s, &sys.rhs, &mut r);
            let rel = pn_krylov::linalg::norm(&r) / pn_krylov::linalg::norm(&sys.rhs);
            assert!(
                (rel - rep_s.stats.relative_residual).abs() <= 1e-6 * rel + 1e-15,
                "{name} {pre:?}: residual of A {rel:e}, from the blocks {:e}",
                rep_s.stats.relative_residual
            );
        }
    }
}

/// σ_t = 0 somewhere (no `--sigma-t-min`): the odd diagonal would vanish there; the split
/// assembly refuses the coefficients with the message of the full assembly instead of
/// dividing by zero.
#[test]
fn zero_extinction_is_an_error_not_a_division() {
    let mut problem = scene("pointsource", Dim::Three, 6, Boundary::Neumann);
    problem.sigma_t = Field::Constant(0.0);
    problem.scattering = pn_runtime::problem::Scattering::Albedo(Field::Constant(0.0));
    let kernel = QuadKernel::new(1, Dim::Three, true);
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    let err = match assemble_split(&problem, &kernel, &layout) {
        Err(e) => format!("{e:#}"),
        Ok(_) => panic!("σ_t = 0 was accepted"),
    };
    assert!(
        err.contains("σ_t = 0") && err.contains("--sigma-t-min"),
        "{err}"
    );
    // The stencil assembly's fast path leaves such rows to the full assembly: the same
    // error (at the first such row it assembles, the middle of a moment's grid).
    let err2 = match pn_runtime::assemble_split::assemble_split_stencil(&problem, &kernel, &layout)
    {
        Err(e) => format!("{e:#}"),
        Ok(_) => panic!("σ_t = 0 was accepted by the stencil assembly"),
    };
    assert!(
        err2.contains("σ_t = 0") && err2.contains("--sigma-t-min"),
        "{err2}"
    );
}

/// The stencil assembly (interior rows through the fast path, the others assembled) on the
/// heterogeneous ball in near-vacuum, odd and even orders: the same diagonals and
/// right-hand side bit for bit, and blocks rebuilt from the stencils equal to the
/// assembled blocks to 1e-14 of the largest entry.
#[test]
fn stencil_assembly_of_a_heterogeneous_medium() {
    for order in [1, 2, 3, 4] {
        let problem = ball_in_near_vacuum(12);
        let kernel = QuadKernel::new(order, Dim::Three, true);
        let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
        let blocks = assemble_split(&problem, &kernel, &layout).unwrap().unwrap();
        let st = pn_runtime::assemble_split::assemble_split_stencil(&problem, &kernel, &layout)
            .unwrap()
            .unwrap();
        let (a, b) = (&blocks.split, &st.split);
        assert!(b.stencil.is_some(), "P_{order}");
        assert_eq!(
            (&a.d_e, &a.d_o, a.nnz_a),
            (&b.d_e, &b.d_o, b.nnz_a),
            "P_{order}"
        );
        assert_eq!(blocks.rhs, st.rhs, "P_{order}");
        assert_eq!(blocks.max_entry, st.max_entry, "P_{order}");
        let (rb, rc) = b.blocks();
        for (want, got) in [(&a.b, &*rb), (&a.c_scaled, &*rc)] {
            let scale = want.data().iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert_eq!(want.indices(), got.indices(), "P_{order}");
            for (w, g) in want.data().iter().zip(got.data()) {
                assert!((w - g).abs() <= 1e-14 * scale, "P_{order}: {g} vs {w}");
            }
        }
    }
}

/// A dense ball (σ_t = 20, albedo 0.9) in near-vacuum (σ_t = 0.02) around the point
/// source's centre: the setting of the render solves.
fn ball_in_near_vacuum(res: usize) -> Problem {
    let mut p = scene("pointsource", Dim::Three, res, Boundary::Dirichlet);
    let (lo, hi) = (p.grid.min, p.grid.max);
    let c = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let r = 0.25 * (hi[0] - lo[0]);
    p.sigma_t = Field::analytic(move |x| {
        let d2: f64 = (0..3).map(|a| (x[a] - c[a]).powi(2)).sum();
        if d2 < r * r {
            20.0
        } else {
            0.02
        }
    });
    p.scattering = pn_runtime::problem::Scattering::Albedo(Field::Constant(0.9));
    p
}

/// Even orders keep the odd-l moments (`Retained::for_layout`): the blocks are those of
/// splitting the assembled matrix with that mask, and the solve gives the answer of the
/// even-parity solve, to the tolerance.
#[test]
fn even_orders_keep_the_odd_moments_with_the_same_answer() {
    for order in [2, 4] {
        let problem = ball_in_near_vacuum(8);
        let kernel = QuadKernel::new(order, Dim::Three, true);
        let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
        assert_eq!(Retained::for_layout(&layout), Retained::Odd, "P_{order}");
        let sys = assemble(&problem, &kernel, &layout).unwrap();
        let odd_mask = retained_mask(&layout, Retained::Odd);
        let reference = split(&sys.matrix, &odd_mask).unwrap();
        let direct = assemble_split(&problem, &kernel, &layout).unwrap().unwrap();
        assert_eq!(direct.split.even, reference.even, "P_{order}");
        assert_eq!(direct.split.b, reference.b, "P_{order}");
        assert_eq!(direct.split.c_scaled, reference.c_scaled, "P_{order}");
        // The kept unknowns are the odd-l ones.
        let odd_count = odd_mask.iter().filter(|&&k| k).count();
        assert_eq!(direct.split.even.len(), odd_count, "P_{order}");
        let tol = 1e-10;
        let kept_odd = ParityCg::for_layout(&layout)
            .solve_split(&direct.split, &direct.rhs, &opts(tol))
            .unwrap();
        let kept_even = ParityCg::new(even_mask(&layout), Precond::Multigrid)
            .with_layout_geometry(&layout)
            .solve_detailed(&sys.matrix, &sys.rhs, &opts(tol))
            .unwrap();
        assert!(
            kept_odd.1.stats.converged() && kept_even.1.stats.converged(),
            "P_{order}: {:?} at residual {:e} / {:?} at residual {:e}",
            kept_odd.1.stats.status,
            kept_odd.1.stats.relative_residual,
            kept_even.1.stats.status,
            kept_even.1.stats.relative_residual
        );
        let d = rel_diff(&kept_odd.0, &kept_even.0);
        assert!(d < 1e-7, "P_{order}: the two reductions differ by {d:e}");
    }
    // Odd orders keep the even-l moments, as before.
    let problem = scene("pointsource", Dim::Three, 6, Boundary::Neumann);
    let kernel = QuadKernel::new(3, Dim::Three, true);
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    assert_eq!(Retained::for_layout(&layout), Retained::Even);
}

/// The reason for keeping the odd moments at even N: in near-vacuum the even-parity
/// system's highest band has no diffusion along some directions, and multigrid-CG needs
/// many times the iterations. Iteration counts are deterministic, so they are compared
/// here; the times are in docs/solvers.md ("Even orders").
#[test]
fn keeping_the_odd_moments_needs_fewer_iterations_in_near_vacuum() {
    let problem = ball_in_near_vacuum(12);
    let kernel = QuadKernel::new(2, Dim::Three, true);
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    let solver =
        ParityCg::new(even_mask(&layout), Precond::Multigrid).with_layout_geometry(&layout);
    let mut its = Vec::new();
    for retained in [Retained::Even, Retained::Odd] {
        let sys = assemble_split_retaining(&problem, &kernel, &layout, retained)
            .unwrap()
            .unwrap();
        let (_, rep) = solver
            .solve_split(&sys.split, &sys.rhs, &opts(1e-8))
            .unwrap();
        assert!(rep.stats.converged(), "{retained:?}");
        its.push(rep.stats.iterations);
    }
    assert!(
        3 * its[1] <= its[0],
        "iterations keeping the even / odd moments: {its:?}"
    );
}

/// Where the even moments cannot be eliminated (σ_a = 0: the checkerboard's scattering
/// blocks), the split keeps the even-l moments instead, and the solve still converges.
#[test]
fn zero_absorption_falls_back_to_keeping_the_even_moments() {
    let problem = scene("checkerboard", Dim::Two, 21, Boundary::Neumann);
    let kernel = QuadKernel::new(2, Dim::Two, true);
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    assert_eq!(Retained::for_layout(&layout), Retained::Odd);
    assert!(
        assemble_split_retaining(&problem, &kernel, &layout, Retained::Odd)
            .unwrap()
            .is_err(),
        "σ_a = 0 must stop the elimination of the even moments"
    );
    let direct = assemble_split(&problem, &kernel, &layout).unwrap().unwrap();
    let sys = assemble(&problem, &kernel, &layout).unwrap();
    assert_eq!(
        direct.split.even,
        split(&sys.matrix, &even_mask(&layout)).unwrap().even
    );
    // The assembled route falls back the same way.
    let solver = ParityCg::for_layout(&layout).with_precond(Precond::Multigrid);
    let (u, rep) = solver
        .solve_detailed(&sys.matrix, &sys.rhs, &opts(1e-9))
        .unwrap();
    assert!(rep.stats.converged());
    assert_eq!(rep.even_unknowns, direct.split.even.len());
    let (u_s, _) = solver
        .solve_split(&direct.split, &direct.rhs, &opts(1e-9))
        .unwrap();
    assert!(rel_diff(&u_s, &u) < 1e-7);
}
