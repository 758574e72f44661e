//! The matrix-free operator against the assembled CSR matrix: `A x`, `Aᵀ x` and the
//! right-hand side on random vectors, for P_1/P_3 in 2D and 3D and CDA, both boundary
//! closures, heterogeneous (checkerboard) and homogeneous (point source) media, on
//! non-cubic grids (so that an axis mix-up in the index arithmetic shows).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod common;

use common::rel_diff;
use pn_codegen::discretize::{cda_ir, pn_ir_for_order};
use pn_krylov::linalg::{spmv, transpose_csr};
use pn_krylov::operator::LinearOperator;
use pn_runtime::assemble::assemble;
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::Layout;
use pn_runtime::MatFreeOperator;
use pn_stencil::InterpretedKernel;
use pn_stencil::Staggering as Placement;
use pn_stencil::{Dim, StencilKernel};

/// Deterministic uniform numbers in [−1, 1) (xorshift64*).
fn random_vector(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s >> 12;
            s ^= s << 25;
            s ^= s >> 27;
            let r = s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
            r as f64 / (1u64 << 52) as f64 - 1.0
        })
        .collect()
}

fn scene(name: &str, dim: Dim, res: &[usize], bc: Boundary) -> Problem {
    let o = BuiltinOptions {
        dim: Some(dim),
        res: Some(res.to_vec()),
        ..Default::default()
    };
    let mut p = builtin(name, &o).unwrap().problem;
    p.boundary = bc;
    p
}

/// Compares the two operators on `problem` with `kernel`; returns the stored weights.
fn check(problem: &Problem, kernel: &dyn StencilKernel, what: &str) -> usize {
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    let sys = assemble(problem, kernel, &layout).unwrap();
    let op = MatFreeOperator::new(problem, kernel, &layout).unwrap();
    let n = layout.len();
    assert_eq!((op.rows(), op.cols()), (n, n));
    // The right-hand side is evaluated by the same kernel call: identical.
    assert_eq!(op.rhs(), &sys.rhs[..], "{what}: rhs");
    let at = transpose_csr(&sys.matrix);
    for seed in 1..=3 {
        let x = random_vector(n, seed);
        let (mut want, mut got) = (vec![0.0; n], vec![f64::NAN; n]);
        // Entries agree except for the order of summation (CSR merges clamped duplicates
        // first): each output is a sum of at most ~40 products of weights and |x| ≤ 1, so
        // the difference is a few ulp of max|w|; 1e-12 relative to max|A x| leaves a margin
        // of ~100 while any wrong index or weight gives O(1).
        spmv(&sys.matrix, &x, &mut want);
        op.apply(&x, &mut got);
        let e = rel_diff(&got, &want);
        assert!(e < 1e-12, "{what}: A x differs by {e:.3e}");
        spmv(&at, &x, &mut want);
        got.fill(f64::NAN);
        op.apply_transpose(&x, &mut got);
        let e = rel_diff(&got, &want);
        assert!(e < 1e-12, "{what}: Aᵀ x differs by {e:.3e}");
    }
    op.stored_weights()
}

fn pn(order: usize, dim: Dim) -> InterpretedKernel {
    InterpretedKernel::new(pn_ir_for_order(order, dim, Placement::Staggered).unwrap())
}

#[test]
fn pn_2d_checkerboard_both_boundaries() {
    for order in [1, 3] {
        let k = pn(order, Dim::Two);
        for bc in [Boundary::Neumann, Boundary::Dirichlet] {
            let p = scene("checkerboard", Dim::Two, &[9, 8], bc);
            let stored = check(&p, &k, &format!("P_{order} 2D {bc:?}"));
            // Heterogeneous: the collision diagonal varies, so weights are stored.
            assert!(stored > 0);
        }
    }
}

#[test]
fn pn_3d_checkerboard_both_boundaries() {
    for order in [1, 3] {
        let k = pn(order, Dim::Three);
        for bc in [Boundary::Neumann, Boundary::Dirichlet] {
            let p = scene("checkerboard3d", Dim::Three, &[6, 5, 4], bc);
            check(&p, &k, &format!("P_{order} 3D {bc:?}"));
        }
    }
}

#[test]
fn cda_2d_and_3d() {
    for (dim, name, res) in [
        (Dim::Two, "checkerboard", vec![9, 8]),
        (Dim::Three, "checkerboard3d", vec![6, 5, 4]),
    ] {
        let k = InterpretedKernel::new(cda_ir(dim).unwrap());
        for bc in [Boundary::Neumann, Boundary::Dirichlet] {
            let p = scene(name, dim, &res, bc);
            check(&p, &k, &format!("CDA {dim:?} {bc:?}"));
        }
    }
}

/// In a homogeneous medium every weight is a constant: under Dirichlet nothing is stored
/// per row at all (only the cell source makes the right-hand side vary).
#[test]
fn homogeneous_point_source_stores_no_weights() {
    let k = pn(1, Dim::Three);
    let p = scene("pointsource", Dim::Three, &[7, 6, 5], Boundary::Dirichlet);
    assert_eq!(check(&p, &k, "P_1 point source Dirichlet"), 0);
    let p = scene("pointsource", Dim::Three, &[7, 6, 5], Boundary::Neumann);
    check(&p, &k, "P_1 point source Neumann");
}
