//! Flux-limited diffusion and CDA on the point-source problem, |E| ≤ φ, input validation and
//! (ignored) convergence measurements.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_runtime::fld::{
    face_flux_ratio, flux_magnitude_ratio, solve_fld, FaceFluence, FldGrid, FldParams, FldProblem,
    FldSolution, Limiter,
};

mod common;
use common::fld::sphere_in_vacuum;

/// CDA Green's function of the infinite medium, normalised: `4πφ/σ_t² = 3 e^{−√(3(1−α))τ}/τ`
/// (docs/design.md §7).
fn cda_infinite(tau: f64, albedo: f64) -> f64 {
    3.0 * (-(3.0 * (1.0 - albedo)).sqrt() * tau).exp() / tau
}

/// Grosjean's approximation, normalised (docs/design.md §7).
fn grosjean(tau: f64, albedo: f64) -> f64 {
    let lambda = (3.0 * (1.0 - albedo) / (2.0 - albedo)).sqrt();
    (-tau).exp() / (tau * tau) + 3.0 * albedo / (2.0 - albedo) * (-lambda * tau).exp() / tau
}

/// `f` summed over the images of a source at the origin in the box `|x_d| < a` with φ = 0 on
/// its faces: images at `2a·m`, sign `(−1)^{m_x+m_y+m_z}` (method of images, separable per
/// axis). `f` takes the optical distance.
fn box_images(x: [f64; 3], a: f64, decay: f64, f: impl Fn(f64) -> f64) -> f64 {
    // Shells beyond m contribute ~e^{−decay·2a·m}; stop at a relative 1e-12.
    let m_max = ((28.0 / (decay * 2.0 * a)).ceil() as i64 + 2).min(60);
    let mut sum = 0.0;
    for mx in -m_max..=m_max {
        for my in -m_max..=m_max {
            for mz in -m_max..=m_max {
                let sign = if (mx + my + mz) % 2 == 0 { 1.0 } else { -1.0 };
                let d = [
                    x[0] - 2.0 * a * mx as f64,
                    x[1] - 2.0 * a * my as f64,
                    x[2] - 2.0 * a * mz as f64,
                ];
                let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                sum += sign * f(r);
            }
        }
    }
    sum
}

/// The FLD paper's point-source test: σ_t = 1, optical width 4 across `n³` cells (n odd, the
/// source in the centre cell), unit power `q = 1/h³` in that cell.
fn point_source(n: usize, albedo: f64) -> FldProblem {
    let grid = FldGrid::cube(n, 4.0).unwrap();
    let len = grid.len();
    let c = (n - 1) / 2;
    let mut source = vec![0.0; len];
    source[grid.index(c, c, c)] = 1.0 / grid.h.powi(3);
    FldProblem {
        grid,
        sigma_t: vec![1.0; len],
        sigma_a: vec![1.0 - albedo; len],
        source,
    }
}

fn solve(problem: &FldProblem, limiter: Limiter) -> FldSolution {
    let params = FldParams::for_grid(limiter, &problem.grid);
    let sol = solve_fld(problem, &params).unwrap();
    sol.into_converged().unwrap()
}

/// Cells along the three positive half-axes from the source, as (τ, linear index) for
/// distances `from..=to` cells.
fn axis_samples(p: &FldProblem, from: usize, to: usize) -> Vec<(f64, usize, [f64; 3])> {
    let n = p.grid.n[0];
    let c = (n - 1) / 2;
    let h = p.grid.h;
    let mut out = Vec::new();
    for s in from..=to {
        let tau = s as f64 * h; // σ_t = 1
        out.push((tau, p.grid.index(c + s, c, c), [tau, 0.0, 0.0]));
        out.push((tau, p.grid.index(c, c + s, c), [0.0, tau, 0.0]));
        out.push((tau, p.grid.index(c, c, c + s), [0.0, 0.0, tau]));
    }
    out
}

const NORM: f64 = 4.0 * std::f64::consts::PI; // 4πφ/σ_t² with σ_t = 1
const ALBEDOS: [f64; 4] = [0.1, 0.5, 0.9, 0.99];
const N: usize = 41;

/// CDA is the same solver with F = 1/3: away from the source it must reproduce the CDA
/// Green's function of the box (infinite-medium Green's function plus its images in the
/// Dirichlet faces, which lie at the boundary-cell centres).
#[test]
fn cda_matches_green_function() {
    for albedo in ALBEDOS {
        let p = point_source(N, albedo);
        let sol = solve(&p, Limiter::Cda);
        let c = (N - 1) / 2;
        let a = c as f64 * p.grid.h;
        let kappa = (3.0 * (1.0 - albedo)).sqrt();
        let mut worst_near: f64 = 0.0;
        let mut worst_far: f64 = 0.0;
        for (tau, idx, x) in axis_samples(&p, 4, c - 1) {
            let want = box_images(x, a, kappa, |t| cda_infinite(t, albedo));
            let rel = (NORM * sol.phi[idx] / want - 1.0).abs();
            if tau < 8.0 * p.grid.h {
                worst_near = worst_near.max(rel);
            } else {
                worst_far = worst_far.max(rel);
            }
        }
        println!("albedo {albedo}: CDA vs Green's function: {worst_near:.4} (4-7 cells), {worst_far:.4} (≥ 8 cells)");
        // Second-order error of the 7-point stencil around a one-cell source, ~(h/r)²: measured
        // 3.4% at 4 cells and ≤ 1.1% beyond 8 cells on 41³ (albedo 0.1, the worst); a wrong D
        // (e.g. 1/σ_t instead of 1/(3σ_t)) or normalisation would be off by tens of percent.
        assert!(
            worst_near < 0.045,
            "albedo {albedo}: CDA error {worst_near} at 4-7 cells"
        );
        assert!(
            worst_far < 0.015,
            "albedo {albedo}: CDA error {worst_far} beyond 8 cells"
        );
    }
}

/// The CDA error against the Green's function is a discretisation error: tripling the
/// resolution (15³ → 45³, same point τ = 0.8 three and nine cells from the source) must shrink
/// it by well over the factor 3 of a first-order scheme (second order: 9).
#[test]
fn cda_error_shrinks_with_resolution() {
    let albedo: f64 = 0.9;
    let kappa = (3.0 * (1.0 - albedo)).sqrt();
    let err = |n: usize, cells: usize| {
        let p = point_source(n, albedo);
        let sol = solve(&p, Limiter::Cda);
        let a = ((n - 1) / 2) as f64 * p.grid.h;
        axis_samples(&p, cells, cells)
            .iter()
            .map(|&(_, idx, x)| {
                let want = box_images(x, a, kappa, |t| cda_infinite(t, albedo));
                (NORM * sol.phi[idx] / want - 1.0).abs()
            })
            .fold(0.0, f64::max)
    };
    let (coarse, fine) = (err(15, 3), err(45, 9));
    println!(
        "CDA error at τ = 0.8: 15³ {coarse:.4}, 45³ {fine:.4}, ratio {:.1}",
        coarse / fine
    );
    assert!(coarse / fine > 5.0, "CDA error {coarse} → {fine}");
}

/// Local log–log slope `d ln φ / d ln τ` between two samples.
fn slope(t0: f64, v0: f64, t1: f64, v1: f64) -> f64 {
    (v1 / v0).ln() / (t1 / t0).ln()
}

/// Near the source, transport is dominated by the uncollided `e^{−τ}/τ²`: FLD must follow it
/// (magnitude and slope) much more closely than CDA, whose `3/τ` is far too low there. Away from
/// the source FLD should lie between CDA and Grosjean (the paper's Figure 5).
#[test]
fn fld_point_source_between_cda_and_transport() {
    for albedo in ALBEDOS {
        let p = point_source(N, albedo);
        let cda = solve(&p, Limiter::Cda);
        let fld = solve(&p, Limiter::LevermorePomraning);
        let h = p.grid.h;
        let c = (N - 1) / 2;
        // Magnitude 2 cells from the source (τ ≈ 0.2), relative to Grosjean.
        let (t2, i2, _) = axis_samples(&p, 2, 2)[0];
        let g2 = grosjean(t2, albedo);
        let err_fld = (NORM * fld.phi[i2] / g2).ln().abs();
        let err_cda = (NORM * cda.phi[i2] / g2).ln().abs();
        // Slope between 2 and 4 cells (τ ≈ 0.2 … 0.4): ballistic −2, Grosjean ≈ −2.2,
        // CDA ≈ −1.1 … −1.6.
        let (t4, i4, _) = axis_samples(&p, 4, 4)[0];
        let s_g = slope(t2, g2, t4, grosjean(t4, albedo));
        let s_fld = slope(t2, fld.phi[i2], t4, fld.phi[i4]);
        let s_cda = slope(t2, cda.phi[i2], t4, cda.phi[i4]);
        // Away from the source: fraction of axis samples (3 cells … 2 cells before the
        // boundary) where FLD lies between CDA and Grosjean (with 2% slack).
        let samples = axis_samples(&p, 3, c - 2);
        let between = samples
            .iter()
            .filter(|&&(tau, idx, _)| {
                let (a, b) = (NORM * cda.phi[idx], grosjean(tau, albedo));
                let f = NORM * fld.phi[idx];
                f >= a.min(b) * 0.98 && f <= a.max(b) * 1.02
            })
            .count() as f64
            / samples.len() as f64;
        let over_grosjean: Vec<f64> = samples
            .iter()
            .map(|&(tau, idx, _)| NORM * fld.phi[idx] / grosjean(tau, albedo))
            .collect();
        let lo = over_grosjean.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = over_grosjean.iter().copied().fold(0.0, f64::max);
        println!("albedo {albedo}: FLD/Grosjean in [{lo:.3}, {hi:.3}] over the same samples");
        println!(
            "albedo {albedo}: at τ={t2:.2} |ln(X/Grosjean)| FLD {err_fld:.3} CDA {err_cda:.3}; \
             slope τ∈[{t2:.2},{t4:.2}] FLD {s_fld:.2} CDA {s_cda:.2} Grosjean {s_g:.2}; \
             FLD between CDA and Grosjean at {:.0}% of τ∈[{:.2},{:.2}]",
            100.0 * between,
            3.0 * h,
            (c - 2) as f64 * h
        );
        assert!(
            err_fld < err_cda,
            "albedo {albedo}: FLD {err_fld} vs CDA {err_cda}"
        );
        assert!(
            err_fld < 0.35,
            "albedo {albedo}: FLD off Grosjean by {err_fld} at τ={t2}"
        );
        // Slopes measured: FLD −2.35 … −1.92, CDA −1.56 … −1.23 (albedo 0.1 … 0.99).
        assert!(
            (s_fld - s_g).abs() < (s_cda - s_g).abs(),
            "albedo {albedo}: slopes {s_fld} {s_cda} {s_g}"
        );
        assert!(
            (s_fld + 2.0).abs() < 0.4,
            "albedo {albedo}: FLD slope {s_fld} is not ballistic"
        );
        if albedo >= 0.9 {
            assert!(
                between > 0.95,
                "albedo {albedo}: FLD between CDA and Grosjean only at {between}"
            );
        } else {
            // Below albedo 0.9 FLD lies *above* Grosjean (and mostly above CDA) beyond the first
            // cells — measured FLD/Grosjean 1.0–1.33 at albedo 0.1 and 1.12–1.23 at 0.5, between
            // CDA and Grosjean at only 56% and 6% of the samples. This is FLD, not the solver:
            // at low albedo the transport solution stays nearly free-streaming (uncollided light,
            // |E|/φ → 1) while its Knudsen number R = |∇φ|/(σ_t φ) ≈ 1 + 2/τ is moderate, and
            // every limiter has R·F(R) < 1 at finite R (LP: 0.67 at R = 3), so FLD must hold
            // a higher φ to carry the source's power outwards. At high albedo the scattered,
            // diffusive part dominates away from the source and FLD tends to CDA there, hence
            // "between". What holds at every albedo, and is asserted: FLD does not undershoot
            // transport (≥ 0.95 Grosjean; Grosjean itself is an approximation at the few-%
            // level) and overshoots it by less than 40%.
            assert!(
                lo > 0.95 && hi < 1.4,
                "albedo {albedo}: FLD/Grosjean in [{lo}, {hi}]"
            );
        }
    }
}

/// Largest value of `ratio` within 2 cells of the source (`near`, d² ≤ 4), beyond (`far`),
/// and between the face neighbours and 4 cells (`shell`, 1 < d² ≤ 16).
fn near_far_shell(p: &FldProblem, ratio: &[f64]) -> (f64, f64, f64) {
    let c = (p.grid.n[0] - 1) / 2;
    let (mut near, mut far, mut shell): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for (idx, &r) in ratio.iter().enumerate() {
        let d2 = p
            .grid
            .cell(idx)
            .iter()
            .map(|&m| (m as f64 - c as f64).powi(2))
            .sum::<f64>();
        if d2 > 4.0 {
            far = far.max(r);
        } else {
            near = near.max(r);
        }
        if d2 > 1.0 && d2 <= 16.0 {
            shell = shell.max(r);
        }
    }
    (near, far, shell)
}

/// `|E| ≤ φ` for the discrete flux of the FLD solution, everywhere including the source cell,
/// while CDA violates it near the source.
///
/// The asserted quantity is the flux through each face against the fluence of the cell it
/// leaves (`FaceFluence::Upwind`): the scheme evaluates the Knudsen number on the face with
/// that φ, so `R·F(R) ≤ 1` bounds it by 1 for every limiter — a wrong face gradient, a
/// Knudsen number from another φ, or D from cells (our first version, 1.2–1.6 at the source)
/// breaks it. The face-mean and cell-centred ratios are printed for the record; they are not
/// bounded by construction (near the source φ drops 3× per cell, so the mean is well below
/// the upwind value).
#[test]
fn flux_bounded_by_fluence() {
    const N_FLUX: usize = 31;
    for albedo in [0.1, 0.9] {
        let p = point_source(N_FLUX, albedo);
        for (limiter, bounded) in [
            (Limiter::LevermorePomraning, true),
            (Limiter::Sum, true),
            (Limiter::Max, true),
            (Limiter::Kershaw, true),
            (Limiter::Larsen(2.0), true),
            (Limiter::Cda, false),
        ] {
            let params = FldParams::for_grid(limiter, &p.grid);
            let sol = solve_fld(&p, &params).unwrap().into_converged().unwrap();
            let up = face_flux_ratio(&p, &params, &sol.phi, FaceFluence::Upwind).unwrap();
            let mean = face_flux_ratio(&p, &params, &sol.phi, FaceFluence::Mean).unwrap();
            let cell = flux_magnitude_ratio(&p, &params, &sol.phi).unwrap();
            let (up_near, up_far, up_shell) = near_far_shell(&p, &up);
            println!("albedo {albedo} {limiter}: |E_f|/φ_up at 1-4 cells {up_shell:.3}");
            let (mean_near, mean_far, _) = near_far_shell(&p, &mean);
            let (cell_near, cell_far, _) = near_far_shell(&p, &cell);
            println!(
                "albedo {albedo} {limiter}: max |E_f|/φ_up within 2 cells {up_near:.3}, beyond \
                 {up_far:.3}; |E_f|/φ_mean {mean_near:.3} / {mean_far:.3}; cell |E|/φ \
                 {cell_near:.3} / {cell_far:.3}"
            );
            if bounded {
                // Bounded by construction up to rounding (φ is far above the floor ε j̄ h here).
                // (max: R·F(R) = 1 exactly for R ≥ 3, so the ratio reaches 1 to rounding.)
                let worst = up_near.max(up_far);
                assert!(worst <= 1.0 + 1e-10, "{limiter}: |E_f|/φ_up = {worst}");
            } else {
                // CDA: continuum |E|/φ = (1/τ + √(3(1−α)))/3 > 1 for τ ≲ 0.4. On the faces
                // of the source cell (h = 0.13) D·Δφ/(h φ_up) ≈ (1 − φ_nb/φ_up)/(3σh): measured
                // 1.75–1.81 within 2 cells and 1.40 at 1–4 cells.
                assert!(
                    up_near > 1.5 && up_shell > 1.2,
                    "CDA should violate |E| ≤ φ near the source, max {up_near} / {up_shell}"
                );
            }
        }
    }
}

/// FLD and CDA converge with vacuum around a dense sphere (σ_ε = 1e-3/L); the solution meets
/// its own stopping test, is positive, and FLD keeps |E| ≤ φ in the vacuum while CDA does not.
#[test]
fn sphere_in_vacuum_converges() {
    let p = sphere_in_vacuum(24);
    for limiter in [Limiter::LevermorePomraning, Limiter::Cda] {
        let params = FldParams::for_grid(limiter, &p.grid);
        let sol = solve_fld(&p, &params).unwrap().into_converged().unwrap();
        let rel = pn_runtime::fld::relative_residual(&p, &params, &sol.phi).unwrap();
        assert!(rel < params.tol, "{limiter}: residual {rel}");
        assert_eq!(sol.residual_history.len(), sol.iterations + 1);
        // Restarting from the converged solution needs no further iteration.
        let again = pn_runtime::fld::solve_fld_from(&p, &params, Some(&sol.phi)).unwrap();
        assert!(again.converged && again.iterations == 0);
        assert!(
            sol.phi.iter().all(|&v| v > 0.0 && v.is_finite()),
            "{limiter}: φ not positive"
        );
        let ratio = face_flux_ratio(&p, &params, &sol.phi, FaceFluence::Upwind).unwrap();
        let max_vacuum = (0..p.grid.len())
            .filter(|&i| p.sigma_t[i] == 0.0)
            .map(|i| ratio[i])
            .fold(0.0, f64::max);
        println!(
            "{limiter}: {} iterations, max |E|/φ in vacuum {max_vacuum:.3}",
            sol.iterations
        );
        if limiter == Limiter::Cda {
            assert!(
                max_vacuum > 1.5,
                "CDA should stream faster than light in vacuum: {max_vacuum}"
            );
        } else {
            // Bounded by construction (see `flux_bounded_by_fluence`).
            assert!(
                max_vacuum <= 1.0 + 1e-10,
                "FLD |E|/φ = {max_vacuum} in vacuum"
            );
        }
    }
}

/// The red–black sweeps and all reductions are deterministic: 1 and 3 threads give the same
/// bits.
#[test]
fn deterministic_across_thread_counts() {
    let p = sphere_in_vacuum(12);
    let params = FldParams::for_grid(Limiter::Kershaw, &p.grid);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| solve_fld(&p, &params).unwrap())
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn non_convergence_is_reported() {
    let p = point_source(15, 0.9);
    let params = FldParams {
        max_iter: 3,
        ..FldParams::for_grid(Limiter::LevermorePomraning, &p.grid)
    };
    let sol = solve_fld(&p, &params).unwrap();
    assert!(!sol.converged);
    assert_eq!(sol.iterations, 3);
    assert!(sol.final_residual() > params.tol);
    let err = sol.into_converged().unwrap_err().to_string();
    assert!(
        err.contains("did not converge") && err.contains("3 iterations"),
        "{err}"
    );
}

#[test]
fn zero_source_gives_zero_fluence() {
    let mut p = point_source(5, 0.5);
    p.source.iter_mut().for_each(|q| *q = 0.0);
    let sol = solve_fld(&p, &FldParams::default()).unwrap();
    assert!(sol.converged && sol.phi.iter().all(|&v| v == 0.0));
}

/// Bad input is an error naming the problem, never a panic.
#[test]
fn invalid_input_is_rejected() {
    let good = point_source(5, 0.5);
    let params = FldParams::for_grid(Limiter::Sum, &good.grid);
    let expect_err = |p: &FldProblem, q: &FldParams, needle: &str| {
        let err = solve_fld(p, q).unwrap_err().to_string();
        assert!(err.contains(needle), "expected {needle:?} in {err:?}");
    };
    let expect_err_from = |p: &FldProblem, q: &FldParams, phi0: &[f64], needle: &str| {
        let err = pn_runtime::fld::solve_fld_from(p, q, Some(phi0))
            .unwrap_err()
            .to_string();
        assert!(err.contains(needle), "expected {needle:?} in {err:?}");
    };
    assert!(solve_fld(&good, &params).is_ok());
    // SOR factor outside (0, 2).
    for omega in [0.0, 2.0, -1.0, 2.5, f64::NAN] {
        expect_err(&good, &FldParams { omega, ..params }, "omega");
    }
    // Vacuum without a positive σ_ε; fine once σ_ε > 0.
    let mut vac = good.clone();
    vac.sigma_t[0] = 0.0;
    vac.sigma_a[0] = 0.0;
    expect_err(
        &vac,
        &FldParams {
            sigma_eps: 0.0,
            ..params
        },
        "vacuum",
    );
    expect_err(
        &vac,
        &FldParams {
            sigma_eps: -1.0,
            ..params
        },
        "sigma_eps",
    );
    assert!(solve_fld(&vac, &params).is_ok());
    // NaN or negative coefficients, σ_a > σ_t, wrong lengths.
    for (field, value, needle) in [
        (0, f64::NAN, "sigma_t"),
        (1, -0.5, "sigma_a"),
        (2, -1.0, "source"),
        (2, f64::INFINITY, "source"),
        (1, 2.0, "exceeds"),
    ] {
        let mut bad = good.clone();
        [&mut bad.sigma_t, &mut bad.sigma_a, &mut bad.source][field][7] = value;
        expect_err(&bad, &params, needle);
    }
    let mut short = good.clone();
    short.source.pop();
    expect_err(&short, &params, "source");
    // Grid too small, bad spacing, bad tolerances and limiter parameters.
    let tiny = FldProblem {
        grid: FldGrid {
            n: [2, 5, 5],
            h: 0.1,
        },
        ..good.clone()
    };
    expect_err(&tiny, &params, "at least 3 cells");
    assert!(FldGrid::new([5, 5, 5], 0.0).is_err());
    assert!(FldGrid::new([5, 5, 5], f64::NAN).is_err());
    expect_err(&good, &FldParams { tol: 0.0, ..params }, "tolerance");
    expect_err(
        &good,
        &FldParams {
            eps: -1.0,
            ..params
        },
        "epsilon",
    );
    expect_err(
        &good,
        &FldParams {
            max_iter: 0,
            ..params
        },
        "max_iter",
    );
    expect_err(
        &good,
        &FldParams {
            limiter: Limiter::Larsen(-2.0),
            ..params
        },
        "Larsen",
    );
    // Helpers check φ's length.
    assert!(flux_magnitude_ratio(&good, &params, &[1.0; 3]).is_err());
    assert!(pn_runtime::fld::solve_fld_from(&good, &params, Some(&[1.0; 3])).is_err());
    let nan_start = vec![f64::NAN; good.grid.len()];
    expect_err_from(&good, &params, &nan_start, "finite");
}

/// Iterations vs resolution and vs σ_ε on the sphere in vacuum (the paper's Figure 4 study).
/// Run with `cargo test --release -p pn-runtime --test fld_solver -- --ignored --nocapture`.
#[test]
#[ignore]
fn convergence_study() {
    println!("limiter  n   sigma_eps*L  omega  iterations  seconds");
    for limiter in [Limiter::LevermorePomraning, Limiter::Cda] {
        for n in [16, 32, 64] {
            let p = sphere_in_vacuum(n);
            let params = FldParams::for_grid(limiter, &p.grid);
            let t = std::time::Instant::now();
            let sol = solve_fld(&p, &params).unwrap();
            println!(
                "{limiter:7} {n:3}  {:9.0e}  {:5.2}  {:6} {}  {:.2}",
                params.sigma_eps,
                params.omega,
                sol.iterations,
                if sol.converged {
                    String::new()
                } else {
                    format!("not converged, residual {:.1e}", sol.final_residual())
                },
                t.elapsed().as_secs_f64()
            );
        }
    }
    for limiter in [Limiter::LevermorePomraning, Limiter::Cda] {
        let p = sphere_in_vacuum(32);
        // The domain is the unit cube, so σ_ε·L = σ_ε.
        for sigma_eps in [1e-1, 1e-2, 1e-3, 1e-4, 1e-5] {
            let params = FldParams {
                sigma_eps,
                ..FldParams::for_grid(limiter, &p.grid)
            };
            let sol = solve_fld(&p, &params).unwrap();
            println!(
                "{limiter:7} {:3}  {sigma_eps:9.0e}  {:5.2}  {:6} {}",
                32,
                params.omega,
                sol.iterations,
                if sol.converged {
                    String::new()
                } else {
                    format!("not converged, residual {:.1e}", sol.final_residual())
                }
            );
        }
    }
    println!("point source (optical width 4): limiter n albedo iterations");
    for limiter in [Limiter::LevermorePomraning, Limiter::Cda] {
        for n in [15, 31, 63] {
            for albedo in [0.1, 0.9, 0.99] {
                let p = point_source(n, albedo);
                let sol = solve_fld(&p, &FldParams::for_grid(limiter, &p.grid)).unwrap();
                println!(
                    "{limiter:7} {n:3} {albedo:5} {:6} {}",
                    sol.iterations,
                    if sol.converged {
                        String::new()
                    } else {
                        format!("not converged, residual {:.1e}", sol.final_residual())
                    }
                );
            }
        }
    }
    let p = sphere_in_vacuum(32);
    for omega in [1.0, 1.3, 1.5, 1.7, 1.8, 1.9, 1.95] {
        let params = FldParams {
            omega,
            max_iter: 5000,
            ..FldParams::for_grid(Limiter::LevermorePomraning, &p.grid)
        };
        let sol = solve_fld(&p, &params).unwrap();
        println!(
            "lp       32  {:9.0e}  {omega:5.2}  {:6} {}",
            params.sigma_eps,
            sol.iterations,
            if sol.converged {
                String::new()
            } else {
                format!("not converged, residual {:.1e}", sol.final_residual())
            }
        );
    }
}
