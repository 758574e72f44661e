//! The Marshak vacuum boundary (docs/design.md §3, "Domain and boundary") against the 1D
//! P_N–Marshak values of tests/data/marshak/README.md and the eigen-decomposition reference
//! of `pn_runtime::reference::slab`: slab reflection and transmission, the Milne
//! extrapolation length, convergence in h (second order: the even moments on the face are
//! extrapolated linearly), the same slab along y and z in 3D, energy balance, a point
//! source in a finite box (Marshak nearer the infinite medium than Dirichlet zero), and the
//! mirror-symmetric checkerboard with Marshak faces under the parity solvers and multigrid.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_kernels::{pn_kernel, Staggering};
use pn_runtime::field::{Field, Point};
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::reference::{pn_marshak_milne, pn_marshak_slab, pn_point_source};
use pn_runtime::scenes::vacuum::{milne_extrapolation_length, slab_fluxes};
use pn_runtime::scenes::{builtin, BuiltinOptions, PointSourceParams};
use pn_runtime::solver::SolverKind;
use pn_stencil::Dim;

mod common;
use common::marshak::{opts, richardson, slab_scene};

/// README tables: (N, R, T_d) for τ = 1, c = 0.9 and (N, z_0).
const SLAB_README: [(usize, f64, f64); 4] = [
    (1, 0.27259, 0.23337),
    (3, 0.26935, 0.22541),
    (5, 0.26838, 0.22398),
    (7, 0.26797, 0.22374),
];
const MILNE_README: [(usize, f64); 4] = [(1, 0.66667), (3, 0.70509), (5, 0.70821), (7, 0.70920)];

fn solve(problem: &Problem, order: usize, dim: Dim, solver: SolverKind) -> Solution {
    let k = pn_kernel(order, dim, Staggering::Staggered).unwrap();
    let sol = solve_problem(problem, k.kernel.as_ref(), solver, &opts()).unwrap();
    assert!(sol.stats.converged(), "P{order}: {:?}", sol.stats);
    let e = sol.energy.as_ref().unwrap();
    // Energy balance: the l = 0 rows are the discrete continuity equation, the outflow is
    // read off the Marshak face unknowns; the imbalance is at the level of the residual.
    assert!(e.relative_imbalance < 1e-8, "P{order}: {e:?}");
    sol
}

fn slab_rt(order: usize, res: usize, tau: f64, albedo: f64) -> (f64, f64) {
    let p = slab_scene(res, tau, albedo, Dim::Two);
    let sol = solve(&p, order, Dim::Two, SolverKind::ParityCg);
    slab_fluxes(&sol.layout, &sol.u).unwrap()
}

/// Slab τ = 1, c = 0.9, P_1 … P_7: at h = 0.01 within 1e-4 of the README (which the issue
/// asks to 1e-3), second-order convergence (the error ratio between h = 0.04, 0.02, 0.01
/// near 4), and the Richardson value within 1e-5 of the eigen-decomposition reference
/// (the README's 5 digits agree with it to 6e-6, see `reference::slab`); R and T approach the
/// transport (S_48) values monotonically as N grows.
#[test]
fn slab_converges_to_the_pn_marshak_values() {
    let mut fine = Vec::new();
    for (n, r_readme, t_readme) in SLAB_README {
        let exact = pn_marshak_slab(n, 1.0, 0.9).unwrap();
        let levels: Vec<(f64, f64)> = [25, 50, 100].map(|r| slab_rt(n, r, 1.0, 0.9)).to_vec();
        let (r, t) = levels[2];
        eprintln!(
            "P{n}: R {:?} T {:?} (exact {:.6} {:.6})",
            levels.iter().map(|l| l.0).collect::<Vec<_>>(),
            levels.iter().map(|l| l.1).collect::<Vec<_>>(),
            exact.reflection,
            exact.transmission
        );
        assert!((r - r_readme).abs() < 1e-4, "P{n} R {r} vs {r_readme}");
        assert!((t - t_readme).abs() < 1e-4, "P{n} T {t} vs {t_readme}");
        for (get, want) in [
            (
                Box::new(|l: &(f64, f64)| l.0) as Box<dyn Fn(&(f64, f64)) -> f64>,
                exact.reflection,
            ),
            (Box::new(|l: &(f64, f64)| l.1), exact.transmission),
        ] {
            let e: Vec<f64> = levels.iter().map(|l| (get(l) - want).abs()).collect();
            let rich = richardson(get(&levels[1]), get(&levels[2]));
            assert!(
                (rich - want).abs() < 1e-5,
                "P{n}: Richardson {rich} vs {want}"
            );
            let ratio = e[1] / e[2];
            assert!(
                (3.0..5.5).contains(&ratio),
                "P{n}: error ratio {ratio} ({e:?})"
            );
        }
        fine.push((r, t));
    }
    // Toward transport (the README's S_48: R 0.26741, T 0.22375) as N grows.
    for w in fine.windows(2) {
        assert!(
            (w[1].0 - 0.26741).abs() < (w[0].0 - 0.26741).abs(),
            "{fine:?}"
        );
        assert!(
            (w[1].1 - 0.22375).abs() < (w[0].1 - 0.22375).abs(),
            "{fine:?}"
        );
    }
}

/// Other thicknesses and albedos against the eigen-decomposition reference: Richardson from
/// h and h/2 within 1e-5, the direct fine value within 1e-4.
#[test]
fn slab_other_tau_and_albedo() {
    for (tau, c) in [(0.5, 0.5), (2.0, 0.99), (4.0, 0.3)] {
        for n in [1, 3, 5] {
            let exact = pn_marshak_slab(n, tau, c).unwrap();
            let cells = (50.0 * tau) as usize;
            let (r1, t1) = slab_rt(n, cells, tau, c);
            let (r2, t2) = slab_rt(n, 2 * cells, tau, c);
            eprintln!(
                "τ {tau} c {c} P{n}: R {r1:.6} {r2:.6} T {t1:.6} {t2:.6} (exact {:.6} {:.6})",
                exact.reflection, exact.transmission
            );
            assert!((r2 - exact.reflection).abs() < 1e-4, "τ {tau} c {c} P{n} R");
            assert!(
                (t2 - exact.transmission).abs() < 1e-4,
                "τ {tau} c {c} P{n} T"
            );
            assert!((richardson(r1, r2) - exact.reflection).abs() < 1e-5);
            assert!((richardson(t1, t2) - exact.transmission).abs() < 1e-5);
        }
    }
}

fn milne_z0(order: usize, res: usize) -> f64 {
    let s = builtin(
        "milne",
        &BuiltinOptions {
            res: Some(vec![res]),
            ..Default::default()
        },
    )
    .unwrap();
    let sol = solve(&s.problem, order, Dim::Two, SolverKind::ParityCg);
    milne_extrapolation_length(&s.problem.grid, &sol.layout, &sol.u).unwrap()
}

/// Milne: z_0 at h = 0.05 within 1e-3 of the README (P_1 exactly 2/3: the linear
/// extrapolation is exact for the P_1 solution), and the Richardson value from h = 0.1,
/// 0.05 within 1e-4 of the README and of the eigen-decomposition reference.
#[test]
fn milne_extrapolation_length_converges() {
    for (n, readme) in MILNE_README {
        let exact = pn_marshak_milne(n).unwrap();
        let (z1, z2) = (milne_z0(n, 300), milne_z0(n, 600));
        let rich = richardson(z1, z2);
        eprintln!("P{n}: z0 {z1:.6} {z2:.6} Richardson {rich:.6} (exact {exact:.6})");
        assert!((z2 - readme).abs() < 1e-3, "P{n}: {z2} vs {readme}");
        assert!((rich - readme).abs() < 1e-4, "P{n}: {rich} vs {readme}");
        assert!((rich - exact).abs() < 1e-4, "P{n}: {rich} vs {exact}");
        if n == 1 {
            assert!((z2 - 2.0 / 3.0).abs() < 1e-8, "{z2}");
        }
    }
}

/// The slab posed along y and along z in 3D (conditions from other harmonics: the ω_y- and
/// ω_z-odd ones) gives the x slab's reflection and transmission, and 3D agrees with 2D.
#[test]
fn slab_along_every_axis_in_3d() {
    let (n, cells) = (3, 40);
    let reference = slab_rt(n, cells, 1.0, 0.9);
    let x3 = slab_scene(cells, 1.0, 0.9, Dim::Three);
    for axis in 0..3 {
        let mut p = x3.clone();
        let mut res = [1; 3];
        res[axis] = cells;
        p.grid.res = res;
        p.grid.max = [1.0; 3];
        let norm = 0.9 / (4.0 * std::f64::consts::PI).sqrt();
        p.sources[0].field = Field::analytic(move |x: Point| norm * (-x[axis]).exp());
        p.boundary = ["x=marshak", "y=marshak", "z=marshak"][axis]
            .parse()
            .unwrap();
        let sol = solve(&p, n, Dim::Three, SolverKind::ParityCg);
        // J_d = √(4π/3) L_1^{(d)} on the d faces: L_1^1 (x), L_1^{-1} (y), L_1^0 (z).
        let m = [1, -1, 0][axis];
        let q = sol
            .layout
            .moments
            .iter()
            .position(|mp| mp.l == 1 && mp.m == m)
            .unwrap();
        let c = (4.0 * std::f64::consts::PI / 3.0).sqrt();
        let mut hi = [0; 3];
        hi[axis] = cells;
        let r = -c * sol.u[sol.layout.index(q, [0; 3])];
        let t = c * sol.u[sol.layout.index(q, hi)];
        eprintln!("axis {axis}: R {r:.9} T {t:.9} (2D x slab {reference:?})");
        assert!((r - reference.0).abs() < 1e-8, "axis {axis}: R {r}");
        assert!((t - reference.1).abs() < 1e-8, "axis {axis}: T {t}");
    }
}

/// A point source in a box of 4 mean free paths (σ_t = 2, α = 0.9 on [0, 2]³) with Marshak
/// faces is closer to the infinite-medium P_N solution than the same box with Dirichlet
/// zero, by the mean relative difference of the fluence over the cells between 2 cells and
/// 1.5 mean free paths from the source; reflecting (Neumann) faces overshoot it.
#[test]
fn point_source_box_marshak_beats_dirichlet() {
    for (order, res) in [(1, 31), (3, 21)] {
        let params = PointSourceParams {
            sigma_t: 2.0,
            albedo: 0.9,
            ..Default::default()
        };
        let scene = builtin(
            "pointsource",
            &BuiltinOptions {
                res: Some(vec![res]),
                pointsource: params,
                ..Default::default()
            },
        )
        .unwrap();
        let modes = pn_point_source(order, 0.9, 0.0).unwrap();
        let g = scene.problem.grid.clone();
        let h = g.h(0);
        let c = (res / 2) as f64 + 0.5;
        let error = |bc: Boundary| -> f64 {
            let mut p = scene.problem.clone();
            p.boundary = bc;
            let sol = solve(&p, order, Dim::Three, SolverKind::ParityCg);
            let phi = sol.l00();
            let (mut sum, mut count) = (0.0, 0usize);
            for i in 0..res {
                for j in 0..res {
                    for k in 0..res {
                        let d = [i, j, k].map(|v| (v as f64 + 0.5 - c) * h);
                        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                        if r < 2.0 * h || 2.0 * r > 1.5 {
                            continue;
                        }
                        let exact = modes.fluence_world(r, 2.0);
                        let got = phi[(i * res + j) * res + k];
                        sum += (got - exact) / exact;
                        count += 1;
                    }
                }
            }
            sum / count as f64
        };
        let (m, d, n) = (
            error(Boundary::Marshak),
            error(Boundary::Dirichlet),
            error(Boundary::Neumann),
        );
        eprintln!("P{order} {res}³: mean relative difference marshak {m:.4} dirichlet {d:.4} neumann {n:.4}");
        assert!(
            m.abs() < 0.5 * d.abs(),
            "P{order}: marshak {m} dirichlet {d}"
        );
        assert!(d < m && m < n, "P{order}: {d} < {m} < {n}");
    }
}

/// The checkerboard with Marshak faces solves with the parity solvers (ILU and multigrid
/// preconditioners agree), converges, balances energy and is mirror-symmetric about
/// x = 3.5, like the lattice.
#[test]
fn checkerboard_with_marshak_faces_is_mirror_symmetric() {
    let n = 31;
    for order in [1, 3] {
        let mut p = builtin(
            "checkerboard",
            &BuiltinOptions {
                res: Some(vec![n]),
                ..Default::default()
            },
        )
        .unwrap()
        .problem;
        p.boundary = Boundary::Marshak;
        let ilu = solve(&p, order, Dim::Two, SolverKind::ParityIlu);
        let mg = solve(&p, order, Dim::Two, SolverKind::ParityMg);
        let (a, b) = (ilu.l00(), mg.l00());
        let max = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut asym = 0.0f64;
        let mut diff = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let v = a[i * n + j];
                asym = asym.max((v - a[(n - 1 - i) * n + j]).abs());
                diff = diff.max((v - b[i * n + j]).abs());
            }
        }
        eprintln!(
            "P{order}: mirror asymmetry {:.2e}, ilu vs mg {:.2e} (relative), outflow {:?}",
            asym / max,
            diff / max,
            ilu.energy.as_ref().map(|e| e.boundary_outflow)
        );
        assert!(asym < 1e-8 * max, "P{order}: asymmetry {asym}");
        assert!(diff < 1e-7 * max, "P{order}: ilu vs mg {diff}");
        assert!(ilu.energy.unwrap().boundary_outflow > 0.0);
    }
}

/// Bad input: even N, the collocated stencil, matrix-free solvers, and too few cells.
#[test]
fn unsupported_combinations_are_refused() {
    let p = slab_scene(20, 1.0, 0.9, Dim::Two);
    let k2 = pn_kernel(2, Dim::Two, Staggering::Staggered).unwrap();
    let e = solve_problem(&p, k2.kernel.as_ref(), SolverKind::ParityCg, &opts())
        .err()
        .unwrap();
    assert!(format!("{e:#}").contains("odd order"), "{e:#}");
    let kc = pn_kernel(3, Dim::Two, Staggering::Collocated).unwrap();
    let e = solve_problem(&p, kc.kernel.as_ref(), SolverKind::Cgnr, &opts())
        .err()
        .unwrap();
    assert!(format!("{e:#}").contains("staggered"), "{e:#}");
    let k3 = pn_kernel(3, Dim::Two, Staggering::Staggered).unwrap();
    let e = solve_problem(&p, k3.kernel.as_ref(), SolverKind::CgnrMf, &opts())
        .err()
        .unwrap();
    assert!(format!("{e:#}").contains("matrix-free"), "{e:#}");
    let thin = slab_scene(1, 1.0, 0.9, Dim::Two);
    let e = solve_problem(&thin, k3.kernel.as_ref(), SolverKind::ParityCg, &opts())
        .err()
        .unwrap();
    assert!(format!("{e:#}").contains("at least 2 cells"), "{e:#}");
    // The assembled CGNR route takes it and agrees with the parity route.
    let a = solve(&p, 3, Dim::Two, SolverKind::Cgnr);
    let b = solve(&p, 3, Dim::Two, SolverKind::ParityCg);
    let (ra, rb) = (
        slab_fluxes(&a.layout, &a.u).unwrap(),
        slab_fluxes(&b.layout, &b.u).unwrap(),
    );
    assert!(
        (ra.0 - rb.0).abs() < 1e-7 && (ra.1 - rb.1).abs() < 1e-7,
        "{ra:?} {rb:?}"
    );
}

/// What the Marshak rows do to the reduced system `S = D_e − B D_o⁻¹ C`
/// (`pn_runtime::marshak`, "Structure"): the block form stays (the split succeeds), but `S` is
/// not symmetric (with Neumann on the same P_1 grid it is), and the parity solver's probe sees it.
#[test]
fn marshak_faces_make_the_reduced_system_nonsymmetric() {
    use pn_runtime::assemble::assemble;
    use pn_runtime::solver::parity::reduced::{ReducedMode, ReducedOperator};
    use pn_runtime::solver::parity::split::split;
    use pn_runtime::solver::parity::SYMMETRY_TOL;
    use pn_runtime::solver::pn_layout::even_mask;
    use pn_runtime::Layout;
    let k = pn_kernel(1, Dim::Two, Staggering::Staggered).unwrap();
    let mut p = builtin(
        "checkerboard",
        &BuiltinOptions {
            res: Some(vec![9]),
            ..Default::default()
        },
    )
    .unwrap()
    .problem;
    for (bc, symmetric) in [(Boundary::Neumann, true), (Boundary::Marshak, false)] {
        p.boundary = bc;
        let layout = Layout::new(&p.grid, k.kernel.moments()).unwrap();
        let sys = assemble(&p, k.kernel.as_ref(), &layout).unwrap();
        let sp = split(&sys.matrix, &even_mask(&layout)).unwrap();
        let op = ReducedOperator::new(&sp, ReducedMode::MatrixFree);
        let asym = op.asymmetry(2);
        eprintln!("P1 {bc:?}: asymmetry probe {asym:.2e}");
        assert_eq!(asym <= SYMMETRY_TOL, symmetric, "{bc:?}: {asym:e}");
    }
}

/// A point source at the centre of a cube with Marshak on every face: the solution is
/// mirror-symmetric in each axis (the conditions of the min and max faces mirror each other),
/// and symmetric under swapping x and y although the edge unknowns odd in both axes take the
/// x condition (`pn_runtime::marshak`, the first axis wins): no other row references them
/// (their neighbours across both faces are Marshak rows, which reference centres only), so
/// the choice does not reach the rest of the solution.
#[test]
fn cube_with_marshak_faces_is_mirror_symmetric() {
    let n = 13;
    let mut p = builtin(
        "pointsource",
        &BuiltinOptions {
            res: Some(vec![n]),
            pointsource: PointSourceParams {
                sigma_t: 4.0,
                ..Default::default()
            },
            ..Default::default()
        },
    )
    .unwrap()
    .problem;
    p.boundary = Boundary::Marshak;
    let sol = solve(&p, 3, Dim::Three, SolverKind::ParityCg);
    let phi = sol.l00();
    let at = |i: usize, j: usize, k: usize| phi[(i * n + j) * n + k];
    let max = phi.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let (mut mirror, mut swap, mut face) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let v = at(i, j, k);
                for w in [
                    at(n - 1 - i, j, k),
                    at(i, n - 1 - j, k),
                    at(i, j, n - 1 - k),
                ] {
                    mirror = mirror.max((v - w).abs());
                }
                swap = swap.max((v - at(j, i, k)).abs());
                if i == 0 {
                    face = face.max(v.abs());
                }
            }
        }
    }
    eprintln!(
        "cube P3 {n}³: mirror {:.2e}, x↔y swap {:.2e}, of max {max:.3e} (face max {:.3e})",
        mirror / max,
        swap / max,
        face / max
    );
    assert!(mirror < 1e-8 * max, "mirror asymmetry {mirror}");
    assert!(
        swap < 1e-9 * max,
        "x↔y asymmetry {swap} (face value {face})"
    );
}

/// The condition itself, checked by quadrature independently of the half-range Gram matrix:
/// on the z = 0 face of a z slab (3D, P_3) the radiance rebuilt from the face unknowns and the
/// even moments extrapolated to the face, `L(ω) = Σ L_k Y_k(ω)`, has
/// `∫_{ω_z>0} Y_o L dω = 0` for every ω_z-odd harmonic (Gauss–Legendre in μ = ω_z on (0, 1)
/// times uniform φ: exact for these degrees) to the solver's tolerance (1e-8 of the largest
/// moment; the solve stops at a relative residual of 1e-10), while the outgoing half-range
/// moments are not 0.
#[test]
fn incoming_half_range_moments_vanish_on_the_face() {
    use pn_stencil::quadrature::{gauss_legendre, real_sh};
    let (n, cells) = (3usize, 30usize);
    let mut p = slab_scene(cells, 1.0, 0.9, Dim::Three);
    p.grid.res = [1, 1, cells];
    let norm = 0.9 / (4.0 * std::f64::consts::PI).sqrt();
    p.sources[0].field = Field::analytic(move |x: Point| norm * (-x[2]).exp());
    p.boundary = "z=marshak".parse().unwrap();
    let sol = solve(&p, n, Dim::Three, SolverKind::ParityCg);
    let lay = &sol.layout;
    // Moments on the face z = 0: z-odd ones at face 0, z-even ones extrapolated from centres 0, 1.
    let face: Vec<f64> = (0..lay.moments.len())
        .map(|q| {
            if lay.moments[q].shift[2] == 1 {
                sol.u[lay.index(q, [0, 0, 0])]
            } else {
                1.5 * sol.u[lay.index(q, [0, 0, 0])] - 0.5 * sol.u[lay.index(q, [0, 0, 1])]
            }
        })
        .collect();
    let (mus, ws) = gauss_legendre(8);
    let n_phi = 16;
    let half_moment = |o: usize, incoming: bool| -> f64 {
        let mut s = 0.0;
        for (t, w) in mus.iter().zip(&ws) {
            let mu = if incoming {
                0.5 * (t + 1.0)
            } else {
                -0.5 * (t + 1.0)
            };
            for j in 0..n_phi {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n_phi as f64;
                let l: f64 = lay
                    .moments
                    .iter()
                    .zip(&face)
                    .map(|(mp, v)| v * real_sh(mp.l as usize, mp.m as i64, mu, phi))
                    .sum();
                let mo = &lay.moments[o];
                s += 0.5
                    * w
                    * (2.0 * std::f64::consts::PI / n_phi as f64)
                    * real_sh(mo.l as usize, mo.m as i64, mu, phi)
                    * l;
            }
        }
        s
    };
    let scale = face.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut outgoing = 0.0f64;
    let mut count = 0;
    for o in (0..lay.moments.len()).filter(|&q| lay.moments[q].shift[2] == 1) {
        let inc = half_moment(o, true);
        assert!(inc.abs() < 1e-8 * scale, "moment {o}: incoming {inc:e}");
        outgoing = outgoing.max(half_moment(o, false).abs());
        count += 1;
    }
    assert_eq!(count, n * (n + 1) / 2);
    assert!(outgoing > 1e-3 * scale, "{outgoing}");
}

/// The same check on a genuinely 3D solution, where the conditions with azimuthal
/// dependence about the normal are excited: the point source in a Marshak cube (P_3), at an
/// x = 0 face position. Harmonics of different tangential parity are orthogonal on the half
/// range, so each class of moments sharing the (y, z) staggering (the unknowns at one
/// position) is rebuilt and checked on its own.
#[test]
fn incoming_half_range_moments_vanish_in_3d() {
    use pn_stencil::quadrature::{gauss_legendre, real_sh};
    let n = 9;
    let mut p = builtin(
        "pointsource",
        &BuiltinOptions {
            res: Some(vec![n]),
            pointsource: PointSourceParams {
                sigma_t: 2.0,
                ..Default::default()
            },
            ..Default::default()
        },
    )
    .unwrap()
    .problem;
    p.boundary = Boundary::Marshak;
    let sol = solve(&p, 3, Dim::Three, SolverKind::ParityCg);
    let lay = &sol.layout;
    let (ts, ws) = gauss_legendre(8);
    let n_az = 16;
    let pi = std::f64::consts::PI;
    let (j, k) = (3, 5);
    let mut checked = 0;
    let mut largest = 0.0f64;
    for class in [[0u8, 0u8], [0, 1], [1, 0], [1, 1]] {
        let members: Vec<usize> = (0..lay.moments.len())
            .filter(|&q| lay.moments[q].shift[1..] == class)
            .collect();
        let value = |q: usize| {
            if lay.moments[q].shift[0] == 1 {
                sol.u[lay.index(q, [0, j, k])]
            } else {
                1.5 * sol.u[lay.index(q, [0, j, k])] - 0.5 * sol.u[lay.index(q, [1, j, k])]
            }
        };
        let vals: Vec<f64> = members.iter().map(|&q| value(q)).collect();
        let scale = vals.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for &o in members.iter().filter(|&&q| lay.moments[q].shift[0] == 1) {
            let mo = &lay.moments[o];
            let mut s = 0.0;
            for (t, w) in ts.iter().zip(&ws) {
                let wx = 0.5 * (t + 1.0);
                let r = (1.0 - wx * wx).sqrt();
                for a in 0..n_az {
                    let az = 2.0 * pi * (a as f64 + 0.5) / n_az as f64;
                    let (wy, wz) = (r * az.cos(), r * az.sin());
                    let (mu, phi) = (wz, wy.atan2(wx));
                    let l: f64 = members
                        .iter()
                        .zip(&vals)
                        .map(|(&q, v)| {
                            let mp = &lay.moments[q];
                            v * real_sh(mp.l as usize, mp.m as i64, mu, phi)
                        })
                        .sum();
                    s += 0.5
                        * w
                        * (2.0 * pi / n_az as f64)
                        * real_sh(mo.l as usize, mo.m as i64, mu, phi)
                        * l;
                }
            }
            assert!(
                s.abs() < 1e-8 * scale.max(1e-300),
                "({},{}): {s:e}",
                mo.l,
                mo.m
            );
            largest = largest.max(sol.u[lay.index(o, [0, j, k])].abs() / scale.max(1e-300));
            checked += 1;
        }
    }
    assert_eq!(checked, 6);
    // The face unknowns are not trivially zero: some are of the size of their class.
    assert!(largest > 1e-2, "{largest}");
}
