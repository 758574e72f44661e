//! The Picard route of flux-limited diffusion (each step a linear diffusion solve through the
//! generated stencil) against the red–black Gauss–Seidel route: same discrete operator, same
//! converged answer on the sphere in vacuum; bad input; (ignored) iteration counts.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_codegen::discretize::{cda_ir, diffusion_ir, pn_ir_for_order};
use pn_krylov::linalg::residual;
use pn_runtime::fld::picard::assemble_picard_system;
use pn_runtime::fld::{
    face_diffusion_coefficients, relative_residual, solve_fld, solve_fld_picard, FldParams,
    Limiter, PicardOptions,
};
use pn_runtime::solver::SolverKind;
use pn_stencil::Dim;
use pn_stencil::InterpretedKernel;
use pn_stencil::Staggering;

mod common;
use common::fld::sphere_in_vacuum;

/// The diffusion stencil with D as a field, interpreted from its IR (the root crate passes
/// the compiled `diffusion_3d`; both evaluate the same IR).
fn diffusion_kernel() -> InterpretedKernel {
    InterpretedKernel::new(diffusion_ir(Dim::Three).unwrap())
}

/// A deterministic positive pseudo-random field (xorshift), values in [lo, hi).
fn random_field(len: usize, seed: u64, lo: f64, hi: f64) -> Vec<f64> {
    let mut s = seed.max(1);
    (0..len)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            lo + (hi - lo) * (s >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect()
}

/// The stencil-assembled system is the red–black solver's operator: for an arbitrary φ (not a
/// solution) the RMS of `b − Aφ` over the interior, with D from φ, equals the relative
/// residual the Gauss–Seidel route measures, for every limiter. A different face rule,
/// boundary treatment or source scaling would change it at O(1).
#[test]
fn stencil_system_is_the_gauss_seidel_operator() {
    let mut p = sphere_in_vacuum(9);
    // A heterogeneous, anisotropic-in-space test: random coefficients everywhere.
    let len = p.grid.len();
    p.sigma_t = random_field(len, 7, 0.0, 5.0);
    p.sigma_a = p.sigma_t.iter().map(|s| 0.3 * s).collect();
    p.source = random_field(len, 11, 0.0, 2.0);
    let mut phi = random_field(len, 3, 0.01, 1.0);
    // The boundary layer holds the Dirichlet value ε j̄ h in both routes (FldParams defaults).
    let phi_b = FldParams::default().eps * p.rms_source() * p.grid.h;
    for (c, v) in phi.iter_mut().enumerate() {
        if p.grid.is_boundary(p.grid.cell(c)) {
            *v = phi_b;
        }
    }
    let kernel = diffusion_kernel();
    for limiter in [
        Limiter::Cda,
        Limiter::LevermorePomraning,
        Limiter::Sum,
        Limiter::Max,
        Limiter::Kershaw,
        Limiter::Larsen(2.0),
    ] {
        let params = FldParams::for_grid(limiter, &p.grid);
        let d = face_diffusion_coefficients(&p, &params, &phi).unwrap();
        let rms_source = p.rms_source();
        let sys = assemble_picard_system(&p, &kernel, &d, phi_b).unwrap();
        let [nx, ny, nz] = p.grid.n;
        let x: Vec<f64> = (1..nx - 1)
            .flat_map(|i| (1..ny - 1).flat_map(move |j| (1..nz - 1).map(move |k| (i, j, k))))
            .map(|(i, j, k)| phi[p.grid.index(i, j, k)])
            .collect();
        assert_eq!(sys.matrix.rows(), x.len());
        // 7-point stencil: at most 7 entries per row.
        assert!(sys.matrix.nnz() <= 7 * x.len());
        let mut r = vec![0.0; x.len()];
        residual(&sys.matrix, &x, &sys.rhs, &mut r);
        let rms = (r.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt() / rms_source;
        let want = relative_residual(&p, &params, &phi).unwrap();
        // Same face coefficients, sums in a different order: agreement to a few ulps of the
        // O(1) terms, 1e-12 relative is generous.
        assert!(
            (rms - want).abs() <= 1e-12 * want,
            "{limiter}: stencil residual {rms} vs Gauss–Seidel residual {want}"
        );
        // The matrix is symmetric (D_f is shared by both cells of a face).
        let t = sys.matrix.transpose_view().to_csr();
        for (v, (i, j)) in sys.matrix.iter() {
            let vt = t.get(i, j).copied().unwrap_or(0.0);
            assert!((v - vt).abs() <= 1e-14 * v.abs(), "asymmetric at ({i},{j})");
        }
    }
}

/// With the constant CDA coefficient the problem is linear: one Picard step with a tight
/// linear tolerance is the converged answer.
#[test]
fn cda_converges_in_one_step() {
    let p = sphere_in_vacuum(12);
    let params = FldParams::for_grid(Limiter::Cda, &p.grid);
    let opts = PicardOptions {
        linear_tol: 1e-10,
        ..Default::default()
    };
    let sol = solve_fld_picard(&p, &params, &diffusion_kernel(), &opts, None).unwrap();
    assert!(sol.fld.converged);
    assert_eq!(sol.fld.iterations, 1, "{:?}", sol.fld.residual_history);
    assert_eq!(sol.fld.residual_history.len(), 2);
    assert!(relative_residual(&p, &params, &sol.fld.phi).unwrap() < params.tol);
}

/// The Gauss–Seidel route and the Picard route agree on a sphere of σ_t = 10 in
/// vacuum with σ_ε = 1e-3/L, for Levermore–Pomraning and CDA, and with both linear solvers.
#[test]
fn picard_matches_gauss_seidel_on_sphere_in_vacuum() {
    let p = sphere_in_vacuum(20);
    let kernel = diffusion_kernel();
    for limiter in [Limiter::LevermorePomraning, Limiter::Cda] {
        // Tighter than the default 1e-6 so that the comparison measures the routes, not the
        // stopping point: two iterates with relative residual ≤ 1e-9 differ by at most
        // ‖A⁻¹‖·1e-9·j̄·√N, which on this grid is far below the 1e-6 we assert.
        let params = FldParams {
            tol: 1e-9,
            ..FldParams::for_grid(limiter, &p.grid)
        };
        assert!(
            (params.sigma_eps - 1e-3).abs() < 1e-15,
            "σ_ε = 1e-3/L, L = 1"
        );
        let gs = solve_fld(&p, &params).unwrap().into_converged().unwrap();
        for solver in [SolverKind::ParityCg, SolverKind::Cgnr] {
            let opts = PicardOptions {
                solver,
                ..Default::default()
            };
            let pc = solve_fld_picard(&p, &params, &kernel, &opts, None).unwrap();
            let pc_iter = pc.fld.iterations;
            let lin = pc.total_linear_iterations();
            let pc = pc.fld.into_converged().unwrap();
            assert!(relative_residual(&p, &params, &pc.phi).unwrap() < params.tol);
            assert_eq!(pc.phi_boundary, gs.phi_boundary);
            let max = gs.phi.iter().cloned().fold(0.0, f64::max);
            let max_diff = gs
                .phi
                .iter()
                .zip(&pc.phi)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            // Pointwise in the vacuum too, where φ is orders of magnitude below its maximum.
            let max_rel_vacuum = (0..p.grid.len())
                .filter(|&c| p.sigma_t[c] == 0.0 && !p.grid.is_boundary(p.grid.cell(c)))
                .map(|c| (gs.phi[c] - pc.phi[c]).abs() / gs.phi[c])
                .fold(0.0, f64::max);
            println!(
                "{limiter} {solver:?}: GS {} iterations, Picard {pc_iter} steps ({lin} linear \
                 iterations); max |Δφ|/max φ = {:.2e}, max relative Δφ in vacuum {:.2e}",
                gs.iterations,
                max_diff / max,
                max_rel_vacuum
            );
            assert!(max_diff <= 1e-6 * max, "{limiter}: {max_diff} vs max {max}");
            assert!(max_rel_vacuum <= 1e-5, "{limiter}: {max_rel_vacuum}");
        }
    }
}

/// Starting from the converged Gauss–Seidel answer, the Picard route stops at once (same
/// stopping quantity), and vice versa the red–black solver accepts the Picard answer.
#[test]
fn routes_accept_each_others_answer() {
    let p = sphere_in_vacuum(12);
    let params = FldParams::for_grid(Limiter::LevermorePomraning, &p.grid);
    let kernel = diffusion_kernel();
    let gs = solve_fld(&p, &params).unwrap().into_converged().unwrap();
    let again = solve_fld_picard(
        &p,
        &params,
        &kernel,
        &PicardOptions::default(),
        Some(&gs.phi),
    )
    .unwrap();
    assert!(again.fld.converged && again.fld.iterations == 0);
    let pc = solve_fld_picard(&p, &params, &kernel, &PicardOptions::default(), None)
        .unwrap()
        .fld
        .into_converged()
        .unwrap();
    let back = pn_runtime::fld::solve_fld_from(&p, &params, Some(&pc.phi)).unwrap();
    assert!(back.converged && back.iterations == 0);
}

fn expect_err(result: anyhow::Result<impl std::fmt::Debug>, needle: &str) {
    let msg = format!("{:#}", result.expect_err("expected an error"));
    assert!(
        msg.contains(needle),
        "error {msg:?} does not mention {needle:?}"
    );
}

#[test]
fn bad_input_is_rejected() {
    let p = sphere_in_vacuum(8);
    let params = FldParams::for_grid(Limiter::LevermorePomraning, &p.grid);
    let kernel = diffusion_kernel();
    let opts = PicardOptions::default();
    // CDA's own stencil computes D from σ_t: the Picard route supplies D, not σ_t.
    let cda = InterpretedKernel::new(cda_ir(Dim::Three).unwrap());
    expect_err(
        solve_fld_picard(&p, &params, &cda, &opts, None),
        "does not provide",
    );
    // P_1 has four moments.
    let p1 = InterpretedKernel::new(pn_ir_for_order(1, Dim::Three, Staggering::Staggered).unwrap());
    expect_err(
        solve_fld_picard(&p, &params, &p1, &opts, None),
        "scalar cell-centred",
    );
    let d2 = InterpretedKernel::new(diffusion_ir(Dim::Two).unwrap());
    expect_err(solve_fld_picard(&p, &params, &d2, &opts, None), "3D");
    // σ_ε = 0 with vacuum, ω outside (0, 2): the shared parameter checks.
    let no_eps = FldParams {
        sigma_eps: 0.0,
        ..params
    };
    expect_err(
        solve_fld_picard(&p, &no_eps, &kernel, &opts, None),
        "sigma_eps",
    );
    let bad_omega = FldParams {
        omega: 2.0,
        ..params
    };
    expect_err(
        solve_fld_picard(&p, &bad_omega, &kernel, &opts, None),
        "omega",
    );
    for linear_tol in [0.0, 1.0, f64::NAN] {
        let o = PicardOptions {
            linear_tol,
            ..Default::default()
        };
        expect_err(
            solve_fld_picard(&p, &params, &kernel, &o, None),
            "linear tolerance",
        );
    }
    expect_err(
        solve_fld_picard(&p, &params, &kernel, &opts, Some(&[1.0; 3])),
        "initial fluence",
    );
    // Too few steps: reported as not converged, and into_converged names the residual.
    let one = PicardOptions {
        max_steps: 1,
        ..Default::default()
    };
    let sol = solve_fld_picard(&p, &params, &kernel, &one, None).unwrap();
    assert!(!sol.fld.converged && sol.fld.iterations == 1);
    expect_err(sol.fld.into_converged(), "did not converge");
}

/// Iterations vs resolution and vs σ_ε on the sphere in vacuum for both routes (the paper's
/// Figure 4 study). Run with
/// `cargo test --release -p pn-runtime --test fld_picard -- --ignored --nocapture`.
#[test]
#[ignore]
fn convergence_study_both_routes() {
    let kernel = diffusion_kernel();
    println!("limiter  n   sigma_eps*L  GS-iter  GS-s   Picard-steps  linear-iter  Picard-s");
    let row = |limiter: Limiter, n: usize, sigma_eps: Option<f64>| {
        let p = sphere_in_vacuum(n);
        let mut params = FldParams::for_grid(limiter, &p.grid);
        if let Some(s) = sigma_eps {
            params.sigma_eps = s;
        }
        let t = std::time::Instant::now();
        let gs = solve_fld(&p, &params).unwrap();
        let t_gs = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let pc = solve_fld_picard(&p, &params, &kernel, &PicardOptions::default(), None).unwrap();
        let t_pc = t.elapsed().as_secs_f64();
        println!(
            "{limiter:7} {n:3}  {:9.0e}  {:6}{} {t_gs:6.2}  {:6}{}  {:9}  {t_pc:6.2}",
            params.sigma_eps,
            gs.iterations,
            if gs.converged { " " } else { "*" },
            pc.fld.iterations,
            if pc.fld.converged { " " } else { "*" },
            pc.total_linear_iterations(),
        );
    };
    for limiter in [Limiter::LevermorePomraning, Limiter::Cda] {
        for n in [16, 24, 32, 48, 64] {
            row(limiter, n, None);
        }
        for s in [1e-1, 1e-2, 1e-4, 1e-5] {
            row(limiter, 32, Some(s));
        }
    }
    println!("(* = not converged)");
}

/// Picard steps vs the linear tolerance of each step (LP, sphere in vacuum, 24³). Run with
/// `cargo test --release -p pn-runtime --test fld_picard linear_tolerance -- --ignored --nocapture`.
#[test]
#[ignore]
fn linear_tolerance_study() {
    let kernel = diffusion_kernel();
    let p = sphere_in_vacuum(24);
    let params = FldParams::for_grid(Limiter::LevermorePomraning, &p.grid);
    println!("linear_tol  Picard-steps  linear-iter  seconds");
    for linear_tol in [0.5, 1e-1, 1e-2, 1e-4, 1e-8] {
        let opts = PicardOptions {
            linear_tol,
            ..Default::default()
        };
        let t = std::time::Instant::now();
        let pc = solve_fld_picard(&p, &params, &kernel, &opts, None).unwrap();
        println!(
            "{linear_tol:9.0e}  {:6}{}  {:9}  {:.2}",
            pc.fld.iterations,
            if pc.fld.converged { " " } else { "*" },
            pc.total_linear_iterations(),
            t.elapsed().as_secs_f64()
        );
    }
}

/// Anderson acceleration changes how fast a fixed-point iteration converges, not where: on
/// the linear contraction x ↦ M x + c in R⁴ (spectral radius 0.95, non-normal) plain
/// iteration needs hundreds of steps to 1e-10, Anderson over 5 steps at most 8 (for a
/// linear map it is GMRES in disguise: exact after dim + 1 steps up to rounding), and both
/// end at the fixed point (I − M)⁻¹ c. The positivity safeguard: when the combination
/// would make a positive component non-positive, the plain step is taken.
#[test]
fn anderson_accelerates_a_fixed_point_iteration_without_moving_it() {
    use pn_runtime::fld::picard::Anderson;
    let m = [
        [0.95, 0.3, 0.0, 0.0],
        [0.0, 0.5, 0.2, 0.0],
        [0.0, 0.0, -0.7, 0.4],
        [0.1, 0.0, 0.0, 0.2],
    ];
    let c = [1.0, 2.0, -1.0, 0.5];
    let map = |x: &[f64]| -> Vec<f64> {
        (0..4)
            .map(|i| (0..4).map(|j| m[i][j] * x[j]).sum::<f64>() + c[i])
            .collect()
    };
    let run = |depth: usize| -> (Vec<f64>, usize) {
        let mut acc = Anderson::new(depth);
        let mut x = vec![0.0; 4];
        for k in 1..=5000 {
            let f: Vec<f64> = map(&x).iter().zip(&x).map(|(g, v)| g - v).collect();
            if f.iter().map(|v| v * v).sum::<f64>().sqrt() < 1e-10 {
                return (x, k);
            }
            x = acc.step(&x, &f);
        }
        (x, usize::MAX)
    };
    let (plain, plain_steps) = run(0);
    let (fast, fast_steps) = run(5);
    assert!(plain_steps > 200 && plain_steps < 5000, "{plain_steps}");
    assert!(fast_steps <= 8, "Anderson took {fast_steps} steps");
    for (a, b) in plain.iter().zip(&fast) {
        assert!(
            (a - b).abs() < 1e-8 * (1.0 + a.abs()),
            "{plain:?} vs {fast:?}"
        );
    }
    // Safeguard: x = 1 → 0.5 → 0.05 extrapolates (γ = −9) to 0.05 + 9·(0.05 − 0.5) = −4;
    // the plain step 0.05 is taken instead.
    let mut acc = Anderson::new(3);
    assert_eq!(acc.step(&[1.0], &[-0.5]), vec![0.5]);
    let next = acc.step(&[0.5], &[-0.45]);
    assert!((next[0] - 0.05).abs() < 1e-15, "{next:?}");
}
