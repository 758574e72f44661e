//! The box partition's operator against one box, in one process (no MPI): one application
//! of the reduced operator `S` and the reduced right-hand side on 2, 3 and 4 boxes equal one
//! box bit for bit; one box equals the serial parity solver's `S` (pn-runtime) to rounding.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use pn_distributed::{Decomposition, SimulatedRanks};
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::Layout;
use pn_stencil::{Dim, Staggering};

fn scene(name: &str, res: usize, bc: Option<Boundary>) -> Problem {
    let opts = BuiltinOptions {
        dim: Some(Dim::Three),
        res: Some(vec![res]),
        ..BuiltinOptions::default()
    };
    let mut p = builtin(name, &opts).unwrap().problem;
    if let Some(bc) = bc {
        p.boundary = bc;
    }
    p
}

/// A vector with a different value at every unknown (no symmetry for errors to hide in).
fn probe(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| ((i as f64 * 0.618_033_988_75).fract() - 0.5) * (1.0 + (i % 7) as f64))
        .collect()
}

fn check_partitions(problem: &Problem, order: usize, splits: &[[usize; 3]]) {
    let choice = pn_kernels::pn_kernel(order, Dim::Three, Staggering::Staggered).unwrap();
    let kernel = choice.kernel.as_ref();
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    let res = problem.grid.res;
    let one = SimulatedRanks::build(
        problem,
        kernel,
        &layout,
        &Decomposition::new(res, [1; 3]).unwrap(),
    )
    .unwrap();
    let x = probe(layout.len());
    let y1 = one.apply(&x);
    let f1 = one.reduced_rhs();
    assert!(y1.iter().any(|v| *v != 0.0));
    for &procs in splits {
        let dec = Decomposition::new(res, procs).unwrap();
        let many = SimulatedRanks::build(problem, kernel, &layout, &dec).unwrap();
        let ghosts: usize = many
            .parts
            .iter()
            .map(|p| p.kept.ghosts.len() + p.elim.ghosts.len())
            .sum();
        assert!(
            ghosts > 0,
            "{procs:?}: a split without ghosts tests nothing"
        );
        let y = many.apply(&x);
        let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        let diff = y
            .iter()
            .zip(&y1)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(
            diff, 0,
            "{procs:?}: {diff} values of S x differ from one box"
        );
        assert_eq!(
            bits(&many.reduced_rhs()),
            bits(&f1),
            "{procs:?}: reduced rhs"
        );
    }
}

#[test]
fn odd_grid_neumann_faces_on_box_edges() {
    // checkerboard3d: Neumann (extrapolation) faces, whose clamped references lie on the
    // boxes' outer faces; 37³ splits unevenly (12/12/13, 18/19).
    let p = scene("checkerboard3d", 37, None);
    assert_eq!(p.boundary, Boundary::Neumann);
    check_partitions(&p, 3, &[[2, 1, 1], [3, 1, 1], [4, 1, 1], [1, 2, 2]]);
}

#[test]
fn marshak_and_dirichlet_faces() {
    let p = scene("pointsource", 13, Some(Boundary::Marshak));
    check_partitions(&p, 3, &[[4, 1, 1], [1, 2, 2], [1, 1, 3]]);
    let p = scene("pointsource", 12, Some(Boundary::Dirichlet));
    check_partitions(&p, 1, &[[2, 2, 1], [1, 1, 4]]);
}

#[test]
fn even_order_keeps_the_odd_moments() {
    let p = scene("pointsource", 11, Some(Boundary::Neumann));
    check_partitions(&p, 2, &[[2, 1, 1], [1, 3, 1]]);
}

#[test]
fn one_box_equals_the_serial_parity_operator() {
    use pn_runtime::solver::parity::reduced::{ReducedMode, ReducedOperator};
    use pn_runtime::solver::parity::split::split;
    use pn_runtime::solver::pn_layout::{retained_mask, Retained};
    let p = scene("pointsource", 9, Some(Boundary::Marshak));
    let choice = pn_kernels::pn_kernel(3, Dim::Three, Staggering::Staggered).unwrap();
    let kernel = choice.kernel.as_ref();
    let layout = Layout::new(&p.grid, kernel.moments()).unwrap();
    let sys = pn_runtime::assemble::assemble(&p, kernel, &layout).unwrap();
    let mask = retained_mask(&layout, Retained::for_layout(&layout));
    let sp = split(&sys.matrix, &mask).unwrap();
    let op = ReducedOperator::new(&sp, ReducedMode::MatrixFree);
    let x = probe(layout.len());
    let x_e: Vec<f64> = sp.even.iter().map(|&g| x[g]).collect();
    let mut y_e = vec![0.0; x_e.len()];
    op.apply(&x_e, &mut y_e);
    let one = SimulatedRanks::build(
        &p,
        kernel,
        &layout,
        &Decomposition::new(p.grid.res, [1; 3]).unwrap(),
    )
    .unwrap();
    let y = one.apply(&x);
    let scale = y_e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (k, &g) in sp.even.iter().enumerate() {
        assert!(
            (y[g] - y_e[k]).abs() <= 1e-13 * scale,
            "unknown {g}: {} vs {}",
            y[g],
            y_e[k]
        );
    }
}

/// CDA has no parity structure: the system is split as it stands (`A x`, no elimination).
#[test]
fn cda_is_split_without_elimination() {
    let p = scene("checkerboard3d", 15, None);
    let choice = pn_kernels::cda_kernel(Dim::Three).unwrap();
    let kernel = choice.kernel.as_ref();
    let layout = Layout::new(&p.grid, kernel.moments()).unwrap();
    let one = SimulatedRanks::build(
        &p,
        kernel,
        &layout,
        &Decomposition::new(p.grid.res, [1; 3]).unwrap(),
    )
    .unwrap();
    assert!(one.parts[0].is_direct());
    let x = probe(layout.len());
    let y1 = one.apply(&x);
    // One box against the assembled matrix.
    let a = pn_runtime::assemble::assemble(&p, kernel, &layout)
        .unwrap()
        .matrix;
    let scale = y1.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, row) in a.outer_iterator().enumerate() {
        let ax: f64 = row.iter().map(|(j, v)| v * x[j]).sum();
        assert!((ax - y1[i]).abs() <= 1e-13 * scale, "row {i}");
    }
    for procs in [[3, 1, 1], [1, 2, 2]] {
        let many = SimulatedRanks::build(
            &p,
            kernel,
            &layout,
            &Decomposition::new(p.grid.res, procs).unwrap(),
        )
        .unwrap();
        let y = many.apply(&x);
        assert!(
            y.iter().zip(&y1).all(|(a, b)| a.to_bits() == b.to_bits()),
            "{procs:?}"
        );
    }
}

#[test]
fn refuses_boxes_thinner_than_the_ghost_layer() {
    let e = Decomposition::new([37, 37, 37], [19, 1, 1]).unwrap_err();
    assert!(
        e.to_string().contains("at most 18 processes along x"),
        "{e}"
    );
}
