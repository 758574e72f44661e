//! The runtime against StaRMAP, using the independent quadrature stencil of `common`
//! (so the runtime is checked without the code generator).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod common;

use common::{coupling_matrices, read_csv, reference_dir, rel_diff, QuadKernel};
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::{SolverKind, SolverOptions};
use pn_stencil::Dim;

fn checkerboard(dim: Dim, res: Vec<usize>) -> Problem {
    builtin(
        "checkerboard",
        &BuiltinOptions {
            dim: Some(dim),
            res: Some(res),
            ..Default::default()
        },
    )
    .unwrap()
    .problem
}

fn solve(problem: &Problem, order: i32, staggered: bool, tol: f64) -> Solution {
    let kernel = QuadKernel::new(order, problem.grid.dim, staggered);
    let opts = SolverOptions {
        tol,
        ..Default::default()
    };
    let sol = solve_problem(problem, &kernel, SolverKind::Cgnr, &opts).unwrap();
    assert!(sol.stats.converged(), "{:?}", sol.stats.status);
    sol
}

#[test]
fn quadrature_p1_matches_hand_check() {
    // docs/design.md §2.2: the (0,0)–(1,1) x-coupling is 1/√3.
    let m = coupling_matrices(&[(0, 0), (1, -1), (1, 0), (1, 1)]);
    assert!((m[0][0][3] - 1.0 / 3f64.sqrt()).abs() < 1e-14);
    assert!((m[1][0][1] - 1.0 / 3f64.sqrt()).abs() < 1e-14);
    assert!((m[2][0][2] - 1.0 / 3f64.sqrt()).abs() < 1e-14);
    assert!(m[0][0][1].abs() < 1e-14);
}

/// StaRMAP's fixed point satisfies the same discrete equations; the CSV holds 11 significant
/// digits and StaRMAP's steady state is converged to ~1e-8 relative (README), so 1e-6 of the
/// maximum leaves two orders of margin. Our residual 1e-10 is far below that.
#[test]
fn p1_checkerboard_matches_starmap() {
    let dir = reference_dir();
    let sol = solve(&checkerboard(Dim::Two, vec![71]), 1, true, 1e-10);
    let err = rel_diff(&sol.l00(), &read_csv(&dir.join("starmap_p1_n71.csv")));
    eprintln!(
        "P1: {} iterations, {:.2}s, max rel diff {err:.3e}",
        sol.stats.iterations, sol.seconds_solve
    );
    assert!(err <= 1e-6, "P1 differs from StaRMAP by {err:.3e} of max");
}

#[test]
fn p5_checkerboard_matches_starmap() {
    let dir = reference_dir();
    let sol = solve(&checkerboard(Dim::Two, vec![71]), 5, true, 1e-10);
    let err = rel_diff(&sol.l00(), &read_csv(&dir.join("starmap_p5_n71.csv")));
    eprintln!(
        "P5: {} iterations, {:.2}s, max rel diff {err:.3e}",
        sol.stats.iterations, sol.seconds_solve
    );
    assert!(err <= 1e-6, "P5 differs from StaRMAP by {err:.3e} of max");
}

/// One cell in z with z-independent fields: the z-shifted moments decouple and vanish, so
/// the 3D solve reduces to the 2D equations (up to solver tolerance).
#[test]
fn three_d_with_one_z_cell_equals_two_d() {
    let two = solve(&checkerboard(Dim::Two, vec![21]), 3, true, 1e-11);
    let three = solve(&checkerboard(Dim::Three, vec![21, 21, 1]), 3, true, 1e-11);
    let err = rel_diff(&three.l00(), &two.l00());
    assert!(err < 1e-8, "3D(nz=1) vs 2D: {err:.3e}");
}

/// The checkerboard is mirror symmetric in x: L(i, j) = L(n−1−i, j) up to solver tolerance.
#[test]
fn mirror_symmetry_and_energy_balance() {
    let sol = solve(&checkerboard(Dim::Two, vec![31]), 3, true, 1e-11);
    let u = sol.l00();
    let n = 31;
    let max = u.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let mut asym = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            asym = asym.max((u[i * n + j] - u[(n - 1 - i) * n + j]).abs());
        }
    }
    assert!(asym / max < 1e-8, "asymmetry {asym:.3e}");
    let e = sol.energy.expect("energy balance");
    assert_eq!(e.outflow_method, "faces");
    // Extrapolation closes the face rows with a zero difference, so the boundary is
    // reflecting: no outflow, everything emitted is absorbed.
    assert!(e.boundary_outflow.abs() < 1e-8 * e.source_power, "{e:?}");
    // Integrating the discrete l = 0 equation gives P_Q = P_A + P_B exactly; what remains
    // is the (relative 1e-11) residual.
    assert!(e.relative_imbalance < 1e-8, "{e:?}");
    // Source 1 on the cells whose centres lie in (3,4)²: (i+½)·7/31 ∈ (3,4) for i = 13..=17.
    let h = 7.0 / 31.0;
    let expected = (4.0 * std::f64::consts::PI).sqrt() * 25.0 * h * h;
    assert!((e.source_power - expected).abs() < 1e-12, "{e:?}");
}

/// Dirichlet drops out-of-domain references (a zero value outside), so light leaves
/// through the boundary: the answer differs and the outflow is positive, while extrapolation
/// reflects (zero outflow, see above).
#[test]
fn dirichlet_differs_from_neumann() {
    let mut p = checkerboard(Dim::Two, vec![31]);
    let neu = solve(&p, 1, true, 1e-11);
    p.boundary = Boundary::Dirichlet;
    let dir = solve(&p, 1, true, 1e-11);
    let d = rel_diff(&dir.l00(), &neu.l00());
    assert!(d > 1e-3, "Dirichlet and Neumann agree to {d:.3e}");
    let (en, ed) = (neu.energy.clone().unwrap(), dir.energy.clone().unwrap());
    assert!(
        ed.boundary_outflow > 1e-3 * ed.source_power,
        "{en:?} {ed:?}"
    );
    assert!(dir.l00().iter().sum::<f64>() < neu.l00().iter().sum::<f64>());
    assert!(ed.relative_imbalance < 1e-8);
}

/// Checkerboard-mode amplitude: mean |u − (4-neighbour average)| / max u over interior
/// cells. The collocated central-difference discretization decouples odd and even cells and
/// oscillates; the staggered one is smooth.
fn checker_amplitude(u: &[f64], n: usize) -> f64 {
    let max = u.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let mut s = 0.0;
    let mut c = 0;
    for i in 1..n - 1 {
        for j in 1..n - 1 {
            let avg =
                (u[(i - 1) * n + j] + u[(i + 1) * n + j] + u[i * n + j - 1] + u[i * n + j + 1])
                    / 4.0;
            s += (u[i * n + j] - avg).abs();
            c += 1;
        }
    }
    s / c as f64 / max
}

#[test]
fn collocated_oscillates_staggered_does_not() {
    let p = checkerboard(Dim::Two, vec![71]);
    let st = solve(&p, 1, true, 1e-10);
    let co = solve(&p, 1, false, 1e-10);
    let (a_st, a_co) = (
        checker_amplitude(&st.l00(), 71),
        checker_amplitude(&co.l00(), 71),
    );
    eprintln!("checkerboard-mode amplitude: staggered {a_st:.3e}, collocated {a_co:.3e}");
    assert!(
        a_co > 5.0 * a_st,
        "staggered {a_st:.3e} collocated {a_co:.3e}"
    );
}
