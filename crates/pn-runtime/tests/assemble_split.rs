//! Assembly straight into the parity blocks (`assemble_split`) against splitting the
//! assembled matrix, and the parity solve from the blocks alone against the solve with `A`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod common;

use common::{builtin_problem, opts, rel_diff, QuadKernel};
use pn_runtime::assemble::assemble;
use pn_runtime::assemble_split::{assemble_split, has_parity_structure};
use pn_runtime::field::Field;
use pn_runtime::layout::Layout;
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::solver::parity::split::split;
use pn_runtime::solver::parity::{ParityCg, Precond};
use pn_runtime::solver::pn_layout::even_mask;
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
            pn_runtime::linalg::residual(&sys.matrix, &u_s, &sys.rhs, &mut r);
            let rel = pn_runtime::linalg::norm(&r) / pn_runtime::linalg::norm(&sys.rhs);
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
}
