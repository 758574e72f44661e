//! The reduced operator applied from the parity blocks' per-moment stencils
//! (`solver::parity::stencil_s`) against the same operator applied from the blocks.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod common;

use common::{builtin_problem, opts, rel_diff, QuadKernel};
use pn_krylov::operator::LinearOperator;
use pn_runtime::assemble_split::assemble_split;
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::solver::multigrid::Geometry;
use pn_runtime::solver::parity::reduced::ReducedOperator;
use pn_runtime::solver::parity::stencil_s::StencilReduced;
use pn_runtime::solver::parity::{ParityCg, Precond, ReducedMode};
use pn_runtime::solver::LinearSolver;
use pn_runtime::Layout;
use pn_stencil::{Dim, StencilKernel};

fn scene(name: &str, dim: Dim, res: usize, boundary: Boundary) -> Problem {
    let mut p = builtin_problem(name, dim, &[res]);
    p.boundary = boundary;
    p
}

/// Deterministic values in [−1, 1).
fn pseudo_random(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        })
        .collect()
}

/// `S x` from the blocks and from the stencils agree to rounding, 1e-13 relative to the
/// largest entry, for a pseudo-random `x` of `seed`.
fn assert_same_products(
    blocks: &ReducedOperator,
    stencil: &ReducedOperator,
    seed: u64,
    label: &str,
) {
    let n = blocks.len();
    let x = pseudo_random(n, seed);
    let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
    blocks.apply(&x, &mut a);
    stencil.apply(&x, &mut b);
    let d = rel_diff(&b, &a);
    assert!(d <= 1e-13, "{label}: {d:e} of the largest");
}

/// On the heterogeneous 2D checkerboard and the 3D point source, with the reflecting and
/// the zero closure, odd and even orders (an even order keeps the odd moments): the
/// stencils are recovered, few entries are corrections, and `S x` agrees with the blocks'
/// to rounding (1e-13 relative to the largest entry of `S x`).
#[test]
fn stencil_s_equals_the_blocks_s() {
    for (name, dim, res) in [
        ("checkerboard", Dim::Two, 41),
        ("pointsource", Dim::Three, 14),
    ] {
        for bc in [Boundary::Neumann, Boundary::Dirichlet] {
            for order in [1, 3, 4] {
                let label = format!("{name} P_{order} {bc:?}");
                let problem = scene(name, dim, res, bc);
                let kernel = QuadKernel::new(order, dim, true);
                let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
                let split = assemble_split(&problem, &kernel, &layout)
                    .unwrap()
                    .unwrap()
                    .split;
                let geometry = Geometry::from_layout(&layout, None);
                let blocks = ReducedOperator::new(&split, ReducedMode::MatrixFree);
                let stencil =
                    ReducedOperator::new(&split, ReducedMode::MatrixFree).with_stencil(&geometry);
                assert!(stencil.is_stencil(), "{label}: stencils not recovered");
                let st = StencilReduced::build(&split, &geometry).unwrap();
                let nnz = split.b.nnz() + split.c_scaled.nnz();
                assert!(
                    st.corrections() * 20 <= nnz,
                    "{label}: {} corrections of {nnz} entries",
                    st.corrections()
                );
                if bc == Boundary::Neumann {
                    assert!(st.corrections() > 0, "{label}: the clamped references");
                }
                for seed in 1..=2 {
                    assert_same_products(&blocks, &stencil, seed, &label);
                }
                assert!(
                    LinearOperator::bytes_per_application(&stencil).unwrap()
                        < LinearOperator::bytes_per_application(&blocks).unwrap(),
                    "{label}"
                );
            }
        }
    }
}

/// Unknowns that are not whole moment grids in the layout's order, and blocks whose rows
/// are mostly not their moment's stencil (a Marshak-closed grid this small: every row near
/// a face), are left to the blocks.
#[test]
fn non_stencil_blocks_are_refused() {
    let problem = scene("pointsource", Dim::Three, 6, Boundary::Neumann);
    let kernel = QuadKernel::new(1, Dim::Three, true);
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    let split = assemble_split(&problem, &kernel, &layout)
        .unwrap()
        .unwrap()
        .split;
    let mut geometry = Geometry::from_layout(&layout, None);
    assert!(StencilReduced::build(&split, &geometry).is_some());
    // Two unknowns of one moment trade places: the order no longer matches the layout's.
    geometry.coords.swap(0, 1);
    assert!(StencilReduced::build(&split, &geometry).is_none());
    // A geometry of the wrong length.
    geometry.coords.pop();
    geometry.class.pop();
    assert!(StencilReduced::build(&split, &geometry).is_none());

    let problem = scene("pointsource", Dim::Three, 4, Boundary::Marshak);
    let kernel = QuadKernel::new(3, Dim::Three, true);
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    let split = assemble_split(&problem, &kernel, &layout)
        .unwrap()
        .unwrap()
        .split;
    let geometry = Geometry::from_layout(&layout, None);
    assert!(StencilReduced::build(&split, &geometry).is_none());
    // The stencil assembly falls back to the blocks there.
    let direct = pn_runtime::assemble_split::assemble_split_stencil(&problem, &kernel, &layout)
        .unwrap()
        .unwrap()
        .split;
    assert!(direct.stencil.is_none() && direct.b == split.b && direct.c_scaled == split.c_scaled);
}

/// The multigrid setup's products from the stencils (`StencilReduced::diagonal`,
/// `StencilReduced::coarse`) against the blocks' (`precond::diagonal`,
/// `galerkin::coarse_from_split`): the same sparsity and values to 1e-13 of the largest
/// entry, on both closures (the reflecting one's clamped references are corrections), odd
/// and even orders, 2D and 3D, and grids of odd and even size (partial aggregates).
#[test]
fn setup_products_equal_the_blocks() {
    use pn_runtime::solver::multigrid::aggregate::aggregate;
    use pn_runtime::solver::parity::galerkin::coarse_from_split;
    use pn_runtime::solver::parity::precond::diagonal;
    let (mut cases, mut levels) = (0, 0);
    for (name, dim, res) in [
        ("checkerboard", Dim::Two, 21),
        ("pointsource", Dim::Three, 9),
        ("pointsource", Dim::Three, 12),
    ] {
        for bc in [Boundary::Neumann, Boundary::Dirichlet, Boundary::Marshak] {
            for order in [1, 3, 4, 5] {
                if bc == Boundary::Marshak && order % 2 == 0 {
                    continue; // Marshak needs an odd order
                }
                let label = format!("{name} {res} P_{order} {bc:?}");
                let problem = scene(name, dim, res, bc);
                let kernel = QuadKernel::new(order, dim, true);
                let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
                let Ok(split) = assemble_split(&problem, &kernel, &layout).unwrap() else {
                    continue;
                };
                let split = split.split;
                let geometry = Geometry::from_layout(&layout, None);
                let Some(st) = StencilReduced::build(&split, &geometry) else {
                    assert_eq!(bc, Boundary::Marshak, "{label}: stencils not recovered");
                    continue;
                };
                let want = diagonal(&split);
                let got = st.diagonal(&split.d_e, &split.d_o);
                let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for (i, (w, g)) in want.iter().zip(&got).enumerate() {
                    assert!(
                        (w - g).abs() <= 1e-13 * scale,
                        "{label}: diag[{i}] {g} vs {w}"
                    );
                }
                let kept = Geometry {
                    class: split.even.iter().map(|&g| geometry.class[g]).collect(),
                    coords: split.even.iter().map(|&g| geometry.coords[g]).collect(),
                };
                let ag = aggregate(&kept);
                let want = coarse_from_split(&split, &ag);
                // Every row of these aggregations is a block of its moment's grid: the
                // position maps compute them all; the general route computes them too.
                let (got, mapped) = st.coarse_with(&split.d_e, &split.d_o, &ag, true);
                assert_eq!(
                    mapped,
                    ag.coarse_len(),
                    "{label}: rows left to the general route"
                );
                let (general, none) = st.coarse_with(&split.d_e, &split.d_o, &ag, false);
                assert_eq!(none, 0, "{label}");
                let scale = want.data().iter().fold(0.0f64, |m, v| m.max(v.abs()));
                // Marshak's face rows may reach coarse columns beyond the moment's terms:
                // then the level is formed as CSR (`coarse_parts` gives `None`).
                match st.coarse_parts(&split.d_e, &split.d_o, &ag) {
                    Some(parts) => {
                        same_level_as_csr(parts, &want, &label);
                        levels += 1;
                    }
                    None => assert_eq!(bc, Boundary::Marshak, "{label}: no stencil level"),
                }
                for got in [got, general] {
                    assert_eq!(want.shape(), got.shape(), "{label}");
                    for (i, (rw, rg)) in want.outer_iterator().zip(got.outer_iterator()).enumerate()
                    {
                        // Entries that cancel to rounding may be stored by one route only.
                        let mut cols: Vec<usize> =
                            rw.indices().iter().chain(rg.indices()).copied().collect();
                        cols.sort_unstable();
                        cols.dedup();
                        for j in cols {
                            let (w, g) = (
                                rw.get(j).copied().unwrap_or(0.0),
                                rg.get(j).copied().unwrap_or(0.0),
                            );
                            assert!(
                                (w - g).abs() <= 1e-13 * scale,
                                "{label}: ({i}, {j}) {g} vs {w}"
                            );
                        }
                    }
                }
                cases += 1;
            }
        }
    }
    assert!(cases >= 24, "only {cases} cases compared");
    assert!(levels >= 20, "only {levels} stencil levels compared");
}

/// The first coarse level built straight as stencil weights (`coarse_parts`) is the CSR
/// `want` to `f32` rounding: the same products (1e-6 of the largest, the `f32` weights'
/// rounding summed over a row) and diagonal, and its asymmetry is found exactly where the
/// CSR's is (above `COARSE_SYMMETRY_TOL`).
fn same_level_as_csr(
    parts: Vec<pn_runtime::solver::multigrid::stencil_level::ClassParts>,
    want: &sprs::CsMat<f64>,
    label: &str,
) {
    use pn_runtime::solver::multigrid::stencil_level::{parts_asymmetry, StencilLevel};
    use pn_runtime::solver::multigrid::COARSE_SYMMETRY_TOL;
    let asym = parts_asymmetry(&parts, COARSE_SYMMETRY_TOL);
    let level = StencilLevel::from_parts(parts).expect("weights fit f32");
    let n = want.rows();
    assert_eq!(level.len(), n, "{label}");
    let x = pseudo_random(n, 7);
    let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
    pn_krylov::linalg::spmv(want, &x, &mut a);
    level.apply(&x, &mut b);
    let d = rel_diff(&b, &a);
    assert!(d <= 1e-6, "{label}: product {d:e} of the largest");
    let d = level.diagonal();
    for (i, row) in want.outer_iterator().enumerate() {
        let w = row.get(i).copied().unwrap_or(0.0);
        assert!((w - d[i]).abs() <= 1e-6 * w.abs(), "{label}: diagonal {i}");
    }
    // The CSR's largest relative entry asymmetry.
    let rowmax: Vec<f64> = want
        .outer_iterator()
        .map(|r| r.data().iter().fold(0.0f64, |m, v| m.max(v.abs())))
        .collect();
    let mut csr_asym = 0.0f64;
    for (i, row) in want.outer_iterator().enumerate() {
        for (j, &v) in row.iter() {
            let t = want.get(j, i).copied().unwrap_or(0.0);
            csr_asym = csr_asym.max((v - t).abs() / (rowmax[i] + rowmax[j]));
        }
    }
    assert_eq!(
        asym > COARSE_SYMMETRY_TOL,
        csr_asym > COARSE_SYMMETRY_TOL,
        "{label}: asymmetry {asym:e} from the parts, {csr_asym:e} from the CSR"
    );
}

/// Assembling straight into the stencils (`assemble_split_stencil`, no blocks stored) gives
/// the same system as assembling the blocks: the same diagonals and right-hand side
/// (bit for bit), the same `S x`, `B t`, `C̃ x` to rounding, and the blocks rebuilt from the
/// stencils (`Split::blocks`) equal to the assembled ones to 1e-14 of the largest entry —
/// on both closures and Marshak, odd and even orders, 2D and 3D.
#[test]
fn stencil_assembly_equals_the_block_assembly() {
    use pn_runtime::assemble_split::assemble_split_stencil;
    let mut cases = 0;
    for (name, dim, res) in [
        ("checkerboard", Dim::Two, 21),
        ("pointsource", Dim::Three, 10),
    ] {
        for bc in [Boundary::Neumann, Boundary::Dirichlet, Boundary::Marshak] {
            for order in [1, 3, 4] {
                if bc == Boundary::Marshak && order % 2 == 0 {
                    continue;
                }
                let label = format!("{name} {res} P_{order} {bc:?}");
                let problem = scene(name, dim, res, bc);
                let kernel = QuadKernel::new(order, dim, true);
                let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
                let blocks = assemble_split(&problem, &kernel, &layout).unwrap().unwrap();
                let st = assemble_split_stencil(&problem, &kernel, &layout)
                    .unwrap()
                    .unwrap();
                let (a, b) = (&blocks.split, &st.split);
                assert!(b.stencil.is_some(), "{label}: assembled as blocks");
                assert_eq!(
                    (b.b.nnz(), b.c_scaled.nnz()),
                    (0, 0),
                    "{label}: blocks stored"
                );
                assert_eq!((&a.even, &a.odd), (&b.even, &b.odd), "{label}");
                assert_eq!((&a.d_e, &a.d_o), (&b.d_e, &b.d_o), "{label}");
                assert_eq!(blocks.rhs, st.rhs, "{label}");
                assert_eq!(a.nnz_a, b.nnz_a, "{label}");
                let (rb, rc) = b.blocks();
                for (want, got, which) in [(&a.b, &*rb, "B"), (&a.c_scaled, &*rc, "C̃")] {
                    let scale = want.data().iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    assert_eq!(want.indptr(), got.indptr(), "{label}: {which} pattern");
                    assert_eq!(want.indices(), got.indices(), "{label}: {which} pattern");
                    for (w, g) in want.data().iter().zip(got.data()) {
                        assert!(
                            (w - g).abs() <= 1e-14 * scale,
                            "{label}: {which} {g} vs {w}"
                        );
                    }
                }
                let op_a = ReducedOperator::new(a, ReducedMode::MatrixFree);
                let op_b = ReducedOperator::new(b, ReducedMode::MatrixFree);
                assert!(op_b.is_stencil(), "{label}");
                assert_same_products(&op_a, &op_b, 3, &label);
                cases += 1;
            }
        }
    }
    assert_eq!(cases, 16);
}

/// The whole multigrid solve with `S` from the stencils and from the blocks: the same
/// answer to well below the tolerance, and the same iteration count up to one (the
/// products differ by rounding).
#[test]
fn solves_agree_with_the_blocks_operator() {
    let problem = scene("checkerboard", Dim::Two, 31, Boundary::Neumann);
    let kernel = QuadKernel::new(3, Dim::Two, true);
    let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
    let sys = pn_runtime::assemble::assemble(&problem, &kernel, &layout).unwrap();
    let solver = ParityCg::for_layout(&layout).with_precond(Precond::Multigrid);
    let mut o = opts(1e-10);
    let (u_st, s_st) = solver.solve(&sys.matrix, &sys.rhs, &o);
    o.tuning.block_operator = true;
    let (u_bl, s_bl) = solver.solve(&sys.matrix, &sys.rhs, &o);
    assert!(s_st.relative_residual <= 1e-10 && s_bl.relative_residual <= 1e-10);
    assert!(
        s_st.iterations.abs_diff(s_bl.iterations) <= 1,
        "{} vs {} iterations",
        s_st.iterations,
        s_bl.iterations
    );
    assert!(
        rel_diff(&u_st, &u_bl) <= 1e-8,
        "{:e}",
        rel_diff(&u_st, &u_bl)
    );
}

/// Grids of 1 to 3 cells per axis, where a stencil term's whole reach can fall outside the
/// grid: the products still agree with the blocks' (the zero closure keeps every row a
/// stencil row, so the stencils are recovered).
#[test]
fn tiny_grids_agree_too() {
    let mut checked = 0;
    for (dim, res) in [
        (Dim::Three, 1),
        (Dim::Three, 2),
        (Dim::Three, 3),
        (Dim::Two, 1),
        (Dim::Two, 2),
    ] {
        for order in [1, 3] {
            let name = if dim == Dim::Three {
                "pointsource"
            } else {
                "checkerboard"
            };
            let label = format!("{name} {res} cells P_{order}");
            let problem = scene(name, dim, res, Boundary::Dirichlet);
            let kernel = QuadKernel::new(order, dim, true);
            let layout = Layout::new(&problem.grid, kernel.moments()).unwrap();
            let Ok(split) = assemble_split(&problem, &kernel, &layout).unwrap() else {
                continue;
            };
            let split = split.split;
            let geometry = Geometry::from_layout(&layout, None);
            let blocks = ReducedOperator::new(&split, ReducedMode::MatrixFree);
            let stencil =
                ReducedOperator::new(&split, ReducedMode::MatrixFree).with_stencil(&geometry);
            assert!(stencil.is_stencil(), "{label}");
            assert_same_products(&blocks, &stencil, 7, &label);
            checked += 1;
        }
    }
    assert!(checked >= 8, "only {checked} tiny grids had a parity split");
}
