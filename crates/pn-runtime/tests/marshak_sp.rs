//! Marshak faces closed by a text PDE's own `boundary marshak` conditions
//! (`pn_runtime::RobinFaces`, docs/pde-text.md "Boundary conditions"): SP_3 (pdes/sp3.pde)
//! against P_3 with Marshak faces in the slab and Milne problems, where the two are the same
//! equations (the slab P_3 system with its odd moments eliminated, conditions included), and
//! against the 1D P_3–Marshak reference with convergence in h; SP_1 and CDA (pdes/sp1.pde,
//! pdes/cda.pde) against P_1 with Marshak faces, which the elimination makes equal in any
//! geometry; the slab along every axis in 3D; and the refusals.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_codegen::text::parse_pde;
use pn_kernels::{pde_kernel, pn_kernel, KernelChoice, Staggering};
use pn_runtime::field::{Field, Point};
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::problem::{Boundary, Problem};
use pn_runtime::reference::{pn_marshak_milne, pn_marshak_slab};
use pn_runtime::scenes::vacuum::{milne_extrapolation_length, slab_fluxes};
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::SolverKind;
use pn_runtime::RobinFaces;
use pn_stencil::Dim;

mod common;
use common::marshak::{opts, richardson, slab_scene};
use common::rel_diff;

/// The kernel of a shipped PDE file.
fn text_kernel(file: &str, dim: Dim) -> KernelChoice {
    common::pde_file_kernel(file, &[], dim)
}

fn solve_with(problem: &Problem, k: &KernelChoice, solver: SolverKind) -> Solution {
    let sol = solve_problem(problem, k.kernel.as_ref(), solver, &opts()).unwrap();
    assert!(
        sol.stats.converged(),
        "{}: {:?}",
        k.kernel.name(),
        sol.stats
    );
    // The L_0^0 rows are the discrete continuity equation: the outflow (read off A u) and the
    // absorption balance the source to the solver's tolerance.
    let e = sol.energy.as_ref().unwrap();
    assert!(e.relative_imbalance < 1e-8, "{}: {e:?}", k.kernel.name());
    sol
}

/// A P_N solve (order `n`, staggered).
fn solve_pn(problem: &Problem, n: usize, dim: Dim) -> Solution {
    solve_with(
        problem,
        &pn_kernel(n, dim, Staggering::Staggered).unwrap(),
        SolverKind::ParityIlu,
    )
}

/// A text-PDE solve (the default solver: parity-cg falls back to GMRES-ILU for SP_3 and to
/// multigrid BiCGSTAB for the one-unknown files).
fn solve_text(problem: &Problem, file: &str, dim: Dim) -> Solution {
    solve_with(problem, &text_kernel(file, dim), SolverKind::ParityCg)
}

/// (R, T) of a text PDE: the flux of its L_0^0 equation through the two x faces.
fn text_rt(problem: &Problem, file: &str, sol: &Solution, dim: Dim) -> (f64, f64) {
    let k = text_kernel(file, dim);
    let faces = RobinFaces::new(problem, &sol.layout, k.kernel.as_ref())
        .unwrap()
        .unwrap();
    let out = |side| {
        faces
            .face_outflow(problem, k.kernel.as_ref(), &sol.layout, &sol.u, (0, side))
            .unwrap()
    };
    (out(0), out(1))
}

/// In a slab, SP_3 with its Marshak conditions is P_3 with Marshak's: the fluence, R and T
/// of pdes/sp3.pde equal the staggered P_3 solution on the same grid to 1e-8 (both solved
/// to a relative residual of 1e-10; the measured differences are ~1e-11). So they converge
/// like P_3 to the 1D P_3–Marshak reference (`pn_marshak_slab`): error ratio 3–5.5 per
/// halving of h (second order), the value at h = 0.01 within 1e-4 and the Richardson value
/// from h = 0.02, 0.01 within 1e-5 — the P_3 test's tolerances (tests/marshak.rs). Other
/// thicknesses and albedos: equal to P_3 and Richardson within 1e-5 of the reference.
#[test]
fn sp3_slab_is_p3_slab_and_converges_to_the_p3_marshak_reference() {
    for (tau, c) in [(1.0, 0.9), (0.5, 0.5), (2.0, 0.99), (4.0, 0.3)] {
        let exact = pn_marshak_slab(3, tau, c).unwrap();
        let cells: Vec<usize> = if tau == 1.0 {
            vec![25, 50, 100]
        } else {
            vec![(50.0 * tau) as usize, (100.0 * tau) as usize]
        };
        let mut levels = Vec::new();
        for &n in &cells {
            let p = slab_scene(n, tau, c, Dim::Two);
            let sp3 = solve_text(&p, "sp3.pde", Dim::Two);
            let p3 = solve_pn(&p, 3, Dim::Two);
            let (r, t) = text_rt(&p, "sp3.pde", &sp3, Dim::Two);
            let (r3, t3) = slab_fluxes(&p3.layout, &p3.u).unwrap();
            let d = rel_diff(&sp3.l00(), &p3.l00());
            eprintln!(
                "τ {tau} c {c}, {n} cells: SP_3 R {r:.9} T {t:.9}, P_3 R {r3:.9} T {t3:.9}, \
                 fluence max rel diff {d:.2e} (reference {:.6} {:.6})",
                exact.reflection, exact.transmission
            );
            assert!(d < 1e-8, "fluence {d}");
            assert!((r - r3).abs() < 1e-8 && (t - t3).abs() < 1e-8, "R/T");
            levels.push((r, t));
        }
        let k = levels.len();
        let (rf, tf) = levels[k - 1];
        assert!((rf - exact.reflection).abs() < 1e-4, "R {rf}");
        assert!((tf - exact.transmission).abs() < 1e-4, "T {tf}");
        let rr = richardson(levels[k - 2].0, rf);
        let tr = richardson(levels[k - 2].1, tf);
        assert!((rr - exact.reflection).abs() < 1e-5, "R Richardson {rr}");
        assert!((tr - exact.transmission).abs() < 1e-5, "T Richardson {tr}");
        if k == 3 {
            for (get, want) in [
                (
                    Box::new(|l: &(f64, f64)| l.0) as Box<dyn Fn(&(f64, f64)) -> f64>,
                    exact.reflection,
                ),
                (Box::new(|l: &(f64, f64)| l.1), exact.transmission),
            ] {
                let e: Vec<f64> = levels.iter().map(|l| (get(l) - want).abs()).collect();
                let (r1, r2) = (e[0] / e[1], e[1] / e[2]);
                eprintln!("error ratios {r1:.2} {r2:.2} ({e:?})");
                assert!(
                    (3.0..5.5).contains(&r1) && (3.0..5.5).contains(&r2),
                    "{e:?}"
                );
            }
        }
    }
}

/// Milne (c = 1, Marshak at x = 0, reflecting at X = 30): SP_3's extrapolation length
/// equals P_3's at h = 0.1 and 0.05 (to 1e-7) and its Richardson value is within 1e-4 of
/// the P_3–Marshak reference (the boundary layer needs fine cells, docs/marshak.md).
#[test]
fn sp3_milne_is_p3_milne() {
    let mut z = Vec::new();
    for n in [300, 600] {
        let s = builtin(
            "milne",
            &BuiltinOptions {
                res: Some(vec![n]),
                ..Default::default()
            },
        )
        .unwrap();
        let p = &s.problem;
        let sp3 = solve_text(p, "sp3.pde", Dim::Two);
        let p3 = solve_pn(p, 3, Dim::Two);
        let z_sp3 = milne_extrapolation_length(&p.grid, &sp3.layout, &sp3.u).unwrap();
        let z_p3 = milne_extrapolation_length(&p.grid, &p3.layout, &p3.u).unwrap();
        eprintln!("{n} cells: z0 SP_3 {z_sp3:.9}, P_3 {z_p3:.9}");
        assert!((z_sp3 - z_p3).abs() < 1e-7, "{z_sp3} vs {z_p3}");
        z.push(z_sp3);
    }
    let exact = pn_marshak_milne(3).unwrap();
    let rich = richardson(z[0], z[1]);
    eprintln!("Richardson {rich:.6}, P_3–Marshak {exact:.6}");
    assert!((rich - exact).abs() < 1e-4, "{rich} vs {exact}");
}

/// SP_1 and CDA with their Robin (Marshak) condition `φ/2 + D ∂_nφ = 0` are P_1 with
/// Marshak faces, not only in 1D: eliminating L_1 from staggered P_1 gives the diffusion
/// stencil, and the face rows `L_1 = ∓(√3/2) L_0(face)` the same flux. The slab's R and T
/// (P_1: 0.272600, 0.233360 at 100 cells), the Milne length (2/3, exact for P_1 at every h),
/// the 2D checkerboard with Marshak faces on all four sides (corners included) and a 3D
/// point source in a Marshak cube: fluence equal to 1e-8 of the maximum (solver tolerance
/// 1e-10).
#[test]
fn sp1_and_cda_are_p1_with_marshak_faces() {
    let p = slab_scene(100, 1.0, 0.9, Dim::Two);
    let p1 = solve_pn(&p, 1, Dim::Two);
    let (r1, t1) = slab_fluxes(&p1.layout, &p1.u).unwrap();
    for file in ["sp1.pde", "cda.pde"] {
        let s = solve_text(&p, file, Dim::Two);
        let (r, t) = text_rt(&p, file, &s, Dim::Two);
        let d = rel_diff(&s.l00(), &p1.l00());
        eprintln!("slab {file}: R {r:.9} T {t:.9} (P_1 {r1:.9} {t1:.9}), fluence diff {d:.2e}");
        assert!((r - r1).abs() < 1e-8 && (t - t1).abs() < 1e-8 && d < 1e-8);
    }
    let milne = builtin(
        "milne",
        &BuiltinOptions {
            res: Some(vec![300]),
            ..Default::default()
        },
    )
    .unwrap()
    .problem;
    for file in ["sp1.pde", "cda.pde"] {
        let s = solve_text(&milne, file, Dim::Two);
        let z = milne_extrapolation_length(&milne.grid, &s.layout, &s.u).unwrap();
        eprintln!("milne {file}: z0 {z:.12}");
        assert!((z - 2.0 / 3.0).abs() < 1e-8, "{file}: {z}");
    }
    let mut cb = builtin(
        "checkerboard",
        &BuiltinOptions {
            res: Some(vec![31]),
            ..Default::default()
        },
    )
    .unwrap()
    .problem;
    cb.boundary = Boundary::Marshak;
    let mut cube = builtin(
        "pointsource",
        &BuiltinOptions {
            res: Some(vec![13]),
            ..Default::default()
        },
    )
    .unwrap()
    .problem;
    cube.boundary = Boundary::Marshak;
    for (name, p, dim) in [("checkerboard", &cb, Dim::Two), ("cube", &cube, Dim::Three)] {
        let p1 = solve_pn(p, 1, dim);
        for file in ["sp1.pde", "cda.pde"] {
            let s = solve_text(p, file, dim);
            let d = rel_diff(&s.l00(), &p1.l00());
            eprintln!("{name} {file}: fluence max rel diff from P_1 {d:.2e}");
            assert!(d < 1e-8, "{name} {file}: {d}");
        }
    }
}

/// The SP_3 slab posed along x, y and z in 3D (conditions on every axis' faces, both sides)
/// gives the 2D x slab's R and T to 1e-8.
#[test]
fn sp3_slab_along_every_axis_in_3d() {
    let cells = 40;
    let p2 = slab_scene(cells, 1.0, 0.9, Dim::Two);
    let s2 = solve_text(&p2, "sp3.pde", Dim::Two);
    let reference = text_rt(&p2, "sp3.pde", &s2, Dim::Two);
    let k = text_kernel("sp3.pde", Dim::Three);
    for axis in 0..3 {
        let mut p = p2.clone();
        p.grid.dim = Dim::Three;
        let mut res = [1; 3];
        res[axis] = cells;
        p.grid.res = res;
        p.grid.max = [1.0; 3];
        let norm = 0.9 / (4.0 * std::f64::consts::PI).sqrt();
        p.sources[0].field = Field::analytic(move |x: Point| norm * (-x[axis]).exp());
        p.boundary = ["x=marshak", "y=marshak", "z=marshak"][axis]
            .parse()
            .unwrap();
        let s = solve_with(&p, &k, SolverKind::ParityCg);
        let faces = RobinFaces::new(&p, &s.layout, k.kernel.as_ref())
            .unwrap()
            .unwrap();
        let out = |side| {
            faces
                .face_outflow(&p, k.kernel.as_ref(), &s.layout, &s.u, (axis, side))
                .unwrap()
        };
        let (r, t) = (out(0), out(1));
        eprintln!("axis {axis}: R {r:.9} T {t:.9} (2D x slab {reference:?})");
        assert!((r - reference.0).abs() < 1e-8, "axis {axis}: R {r}");
        assert!((t - reference.1).abs() < 1e-8, "axis {axis}: T {t}");
    }
}

/// SP_3 on the checkerboard with Marshak faces on all sides (each corner cell reaches
/// across an x and a y face) converges, balances energy and is mirror-symmetric about
/// x = 3.5 to 1e-8 of the maximum, like P_N (tests/marshak.rs), with a positive outflow
/// (SP_3 is not P_3 in 2D, so there is no P_3 value to compare with).
#[test]
fn sp3_checkerboard_with_marshak_faces_is_mirror_symmetric() {
    let n = 31;
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
    let s = solve_text(&p, "sp3.pde", Dim::Two);
    let a = s.l00();
    let max = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut asym = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            asym = asym.max((a[i * n + j] - a[(n - 1 - i) * n + j]).abs());
        }
    }
    let outflow = s.energy.as_ref().unwrap().boundary_outflow;
    eprintln!(
        "SP_3 checkerboard: asymmetry {:.2e}, outflow {outflow}",
        asym / max
    );
    assert!(asym < 1e-8 * max, "{asym}");
    assert!(outflow > 0.0);
}

/// A text PDE without `boundary marshak` statements is refused on Marshak faces (naming the
/// statement), and conditions whose normal-derivative coefficients vanish are an error at
/// assembly, not a panic.
#[test]
fn marshak_faces_need_the_pdes_conditions() {
    let p = slab_scene(20, 1.0, 0.9, Dim::Two);
    let run = |src: &str| -> String {
        let pde = parse_pde(src, &[]).unwrap();
        let k = pde_kernel(&pde, Dim::Two).unwrap();
        match solve_problem(&p, k.kernel.as_ref(), SolverKind::ParityCg, &opts()) {
            Ok(_) => panic!("expected an error for\n{src}"),
            Err(e) => format!("{e:#}"),
        }
    };
    let base =
        "pde t\nunknown u = L(0,0)\nequation u: -div(1/(3*sigma_t)*grad(u)) + sigma_a*u = Q(0,0)\n";
    let e = run(base);
    assert!(e.contains("boundary marshak"), "{e}");
    let e = run(&format!("{base}boundary marshak u: u/2 + 0*dn(u) = 0\n"));
    assert!(e.contains("singular"), "{e}");
    // Faces of other kinds ignore the conditions: SP_3 with Dirichlet faces solves.
    let mut q = p.clone();
    q.boundary = Boundary::Dirichlet;
    solve_text(&q, "sp3.pde", Dim::Two);
}
