//! The 3D point source end to end (docs/design.md §7 "Point source, 3D").
//!
//! * P_1 and CDA on the same grid agree (the paper's claim);
//! * with a Gaussian source, discrete P_1, P_3 and P_5 converge to the
//!   Gaussian-smoothed semi-analytic P_N solution at second order;
//! * the paper's setup (80³, σ_t = 8, α = 0.9, one-cell source) against the semi-analytic
//!   values at τ = 1, 2, 4 (ignored: heavy);
//! * rotational invariance: the face-diagonal profile matches the axis profile;
//! * `pn solve pointsource` writes `profile.csv` / `profile.png` / `profile_diagonal.csv`.
//!
//! Numbers measured with these tests are in `docs/pointsource.md`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_drivers::pointsource_extras::{exact_modes, profile, Ray};
use pn_formats::plot::PROFILE_CSV_HEADER;
use pn_kernels::{cda_kernel, pn_kernel, Dim, Staggering};
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::problem::Boundary;
use pn_runtime::reference::ProfileRow;
use pn_runtime::scenes::{builtin, BuiltinOptions, PointSourceParams, PointSourceShape};
use pn_runtime::solver::{SolverKind, SolverOptions};
use std::process::Command;

/// A point-source solve: `order` 0 means CDA.
struct Run {
    params: PointSourceParams,
    res: usize,
    order: usize,
    boundary: Boundary,
    tol: f64,
}

impl Run {
    fn solve(&self) -> (pn_runtime::problem::Problem, Solution) {
        let scene = builtin(
            "pointsource",
            &BuiltinOptions {
                dim: Some(Dim::Three),
                res: Some(vec![self.res]),
                pointsource: self.params,
                ..Default::default()
            },
        )
        .unwrap();
        let mut problem = scene.problem;
        problem.boundary = self.boundary;
        let choice = if self.order == 0 {
            cda_kernel(Dim::Three).unwrap()
        } else {
            pn_kernel(self.order, Dim::Three, Staggering::Staggered).unwrap()
        };
        let opts = SolverOptions {
            tol: self.tol,
            ..Default::default()
        };
        let t = std::time::Instant::now();
        let sol = solve_problem(
            &problem,
            choice.kernel.as_ref(),
            SolverKind::ParityCg,
            &opts,
        )
        .unwrap();
        assert!(sol.stats.converged(), "{:?}", sol.stats.status);
        eprintln!(
            "  order {} res {} ({} unknowns): {} iterations, {:.2} s",
            self.order,
            self.res,
            sol.unknowns,
            sol.stats.iterations,
            t.elapsed().as_secs_f64()
        );
        (problem, sol)
    }

    fn profile(&self, ray: Ray) -> Vec<ProfileRow> {
        let (problem, sol) = self.solve();
        let modes = exact_modes(self.order, &self.params).unwrap();
        profile(&problem.grid, &sol.l00(), &self.params, &modes, ray).unwrap()
    }
}

/// (a) P_1 and CDA on the same staggered grid. Eliminating the face-centred l = 1 moments of
/// the discrete P_1 system (σ_t constant, so it is the same at faces and centres) gives the
/// 7-point CDA operator exactly, and the closures match too (Dirichlet: the dropped
/// references; Neumann: the clamped ones — measured 2e-13 and 4e-13): the two L_0^0 must
/// agree to solver tolerance. Both are solved to a relative residual of 1e-12; the condition
/// number of these diffusion operators at 24³ is ~1e3, so the solutions agree to ~1e-9
/// relative — we assert 1e-8 (max over all cells, relative to the max).
#[test]
fn p1_equals_cda_on_the_same_grid() {
    for boundary in [Boundary::Dirichlet, Boundary::Neumann] {
        let mk = |order| Run {
            params: PointSourceParams {
                sigma_t: 4.0,
                albedo: 0.9,
                g: 0.0,
                half_width: 1.0,
                source: PointSourceShape::Cell,
            },
            res: 24,
            order,
            boundary,
            tol: 1e-12,
        };
        let (_, p1) = mk(1).solve();
        let (_, cda) = mk(0).solve();
        let (a, b) = (p1.l00(), cda.l00());
        let max = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = a
            .iter()
            .zip(&b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        eprintln!(
            "{boundary:?}: max |P1 − CDA| / max |CDA| = {:.3e}",
            diff / max
        );
        assert!(
            diff / max < 1e-8,
            "P_1 vs CDA ({boundary:?}): {}",
            diff / max
        );
    }
}

/// Max over all cells of |discrete − exact| (normalised fluence `4π L_0^0/σ_t²` against the
/// Gaussian-smoothed P_N solution at the cell centre), divided by the max exact value.
fn gaussian_error(run: &Run) -> f64 {
    let (problem, sol) = run.solve();
    let PointSourceShape::Gaussian(s) = run.params.source else {
        panic!("Gaussian source expected")
    };
    let g = &problem.grid;
    let st = run.params.sigma_t;
    let modes = exact_modes(run.order, &run.params).unwrap();
    let l00 = sol.l00();
    let c = pn_drivers::pointsource_extras::source_cell(g);
    let centre: Vec<f64> = (0..3)
        .map(|d| g.min[d] + (c[d] as f64 + 0.5) * g.h(d))
        .collect();
    let [nx, ny, nz] = g.res;
    let (mut err, mut max) = (0.0f64, 0.0f64);
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let x = [i, j, k].map(|a| a as f64 + 0.5);
                let r = (0..3)
                    .map(|d| (g.min[d] + x[d] * g.h(d) - centre[d]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let exact = modes.fluence_gaussian(st * r, st * s);
                let solved = 4.0 * std::f64::consts::PI / (st * st) * l00[(i * ny + j) * nz + k];
                err = err.max((solved - exact).abs());
                max = max.max(exact);
            }
        }
    }
    err / max
}

/// The Gaussian convergence setup (mean free paths: σ_t = 1): α = 0.3 (slowest P_N decay rate
/// κ ≈ 1.45 for P_1, similar for P_3/P_5), source standard deviation s = 1, domain [0, 12]³
/// with the absorbing (Dirichlet zero) closure. The boundary is ≥ 6 mfp from the source, so
/// its effect on the solution near the source is ~e^{−1.45·12} ≈ 1e-8 relative, far below the
/// discretization error at the finest level (~1e-3).
fn gaussian_run(order: usize, res: usize) -> Run {
    Run {
        params: PointSourceParams {
            sigma_t: 1.0,
            albedo: 0.3,
            g: 0.0,
            half_width: 6.0,
            source: PointSourceShape::Gaussian(1.0),
        },
        res,
        order,
        boundary: Boundary::Dirichlet,
        tol: 1e-11,
    }
}

/// Errors at `resolutions` and the ratios between consecutive ones.
fn convergence(order: usize, resolutions: &[usize]) -> (Vec<f64>, Vec<f64>) {
    let errors: Vec<f64> = resolutions
        .iter()
        .map(|&n| gaussian_error(&gaussian_run(order, n)))
        .collect();
    let ratios: Vec<f64> = errors.windows(2).map(|w| w[0] / w[1]).collect();
    eprintln!("P_{order} at {resolutions:?}: errors {errors:?}, ratios {ratios:?}");
    (errors, ratios)
}

/// Second order: the error must drop by 4 per halving of h; a ratio in [3.3, 4.7] over two
/// halvings (the coarsest h equals s, so the first ratio is still pre-asymptotic by a few
/// percent; a first-order scheme gives 2, a mistake in the smoothed reference a ratio
/// tending to 1).
fn assert_second_order(ratios: &[f64]) {
    assert!(ratios.len() >= 2);
    for r in ratios {
        assert!(
            (3.3..4.7).contains(r),
            "not second order: ratios {ratios:?}"
        );
    }
}

/// (b) P_1 converges to its semi-analytic solution at second order (12³, 24³, 48³).
#[test]
fn p1_gaussian_converges_at_second_order() {
    let (_, ratios) = convergence(1, &[12, 24, 48]);
    assert_second_order(&ratios);
}

/// (b) P_3 likewise (12³, 24³, 48³; 1.8M unknowns at the finest level, a few seconds with
/// parity-CG).
#[test]
fn p3_gaussian_converges_at_second_order() {
    let (_, ratios) = convergence(3, &[12, 24, 48]);
    assert_second_order(&ratios);
}

/// (b) P_5 likewise (48³ is 4.1M unknowns: ~20 s with parity-CG; measured ratios 4.10, 4.03).
#[test]
fn p5_gaussian_converges_at_second_order() {
    let (_, ratios) = convergence(5, &[12, 24, 48]);
    assert_second_order(&ratios);
}

/// Largest difference between the face-diagonal and the axis profiles at the same r, for
/// τ ≤ `tau_max`: both are divided by the exact (radial) solution and the axis ratio is
/// interpolated linearly to the diagonal's τ. The ratio is smooth and close to 1, so the
/// interpolation adds only O(h²)·(a small curvature); interpolating the fluence itself would
/// not work near a Gaussian source, where τ·φ is far from exponential.
///
/// Returns (that difference, the largest |ratio − 1| on either ray: the discretization error).
fn rotational_discrepancy(run: &Run, tau_max: f64) -> (f64, f64) {
    let (problem, sol) = run.solve();
    let modes = exact_modes(run.order, &run.params).unwrap();
    let l00 = sol.l00();
    let axis = profile(&problem.grid, &l00, &run.params, &modes, Ray::Axis).unwrap();
    let diag = profile(&problem.grid, &l00, &run.params, &modes, Ray::Diagonal).unwrap();
    let ratio = |r: &ProfileRow| r.solved / r.pn_exact;
    let error = axis
        .iter()
        .chain(&diag)
        .filter(|r| r.tau <= tau_max)
        .map(|r| (ratio(r) - 1.0).abs())
        .fold(0.0, f64::max);
    let discrepancy = diag
        .iter()
        .filter(|r| r.tau <= tau_max)
        .filter_map(|r| {
            let k = axis
                .windows(2)
                .position(|w| w[0].tau <= r.tau && r.tau <= w[1].tau)?;
            let t = (r.tau - axis[k].tau) / (axis[k + 1].tau - axis[k].tau);
            let a = ratio(&axis[k]) * (1.0 - t) + ratio(&axis[k + 1]) * t;
            Some((ratio(r) - a).abs())
        })
        .fold(0.0, f64::max);
    (discrepancy, error)
}

/// (d) Rotational invariance: along the face diagonal (1,1,0)/√2 the fluence at the same r
/// matches the axis profile within discretization error. The staggered stencil is not
/// rotationally invariant (its O(h²) truncation error, like the 7-point Laplacian's
/// `h²/12 Σ ∂⁴/∂x_i⁴`, depends on the direction): measured at 48³, P_1's relative error is
/// +0.4% … +0.3% along the axis and +0.4% … −0.4% along the diagonal for τ ≤ 3, so the two
/// rays can differ by up to the sum of their errors. Asserted: the difference is at most twice
/// the largest deviation from the exact solution on either ray, and it shrinks at second order
/// (ratio > 3 from 24³ to 48³) — a genuine anisotropy, e.g. a transposed or mis-signed moment,
/// would not shrink. τ ≤ 3 keeps the Dirichlet boundary (6 mfp away) out of the comparison.
#[test]
fn diagonal_profile_matches_axis_profile() {
    let (coarse, coarse_err) = rotational_discrepancy(&gaussian_run(1, 24), 3.0);
    let (fine, fine_err) = rotational_discrepancy(&gaussian_run(1, 48), 3.0);
    eprintln!(
        "P_1 diagonal vs axis, τ ≤ 3: 24³ {coarse:.3e} (error {coarse_err:.3e}), \
         48³ {fine:.3e} (error {fine_err:.3e})"
    );
    assert!(
        fine <= 2.0 * fine_err && coarse <= 2.0 * coarse_err,
        "{fine} {fine_err}"
    );
    assert!(coarse / fine > 3.0, "{coarse} → {fine}");
    let (p3, p3_err) = rotational_discrepancy(&gaussian_run(3, 24), 3.0);
    eprintln!("P_3 diagonal vs axis, τ ≤ 3: 24³ {p3:.3e} (error {p3_err:.3e})");
    assert!(p3 <= 2.0 * p3_err, "P_3 24³: {p3} vs {p3_err}");
}

/// The paper's setup (docs/design.md §7): 80³ cells on [0,2]³, σ_t = 8, α = 0.9, Q_0^0 = 1/h³ in
/// cell (40,40,40), extrapolation (Neumann) closure as in the paper. Returns the relative
/// deviations from the semi-analytic P_N values at τ = 1, 2, 4 (cell centres, since
/// σ_t h = 0.2).
fn paper_deviations(order: usize) -> Vec<f64> {
    let run = Run {
        params: PointSourceParams::default(),
        res: 80,
        order,
        boundary: Boundary::Neumann,
        tol: 1e-10,
    };
    let rows = run.profile(Ray::Axis);
    [1.0, 2.0, 4.0]
        .iter()
        .map(|&t| {
            let r = rows.iter().find(|r| (r.tau - t).abs() < 1e-9).unwrap();
            eprintln!(
                "P_{order} τ={t}: solved {:.5e}, exact {:.5e}, Grosjean {:.5e}",
                r.solved, r.pn_exact, r.grosjean
            );
            r.solved / r.pn_exact - 1.0
        })
        .collect()
}

/// (c) The paper's setup for P_1: within 4% of the semi-analytic values at τ = 1, 2, 4 (the
/// one-cell source is not resolved — σ_t h = 0.2, τ = 1 is five cells out — and the boundary
/// at 8 mfp adds ≈ 1% at τ = 4, docs/design.md §7). Measured: +1.87%, +0.65%, +0.91% (P_1) and
/// +3.24%, +0.81%, +1.03% (P_5; the large-κ modes of higher orders are less resolved near the
/// source). Ignored: 2M unknowns, ~10 s with parity-CG.
#[test]
#[ignore]
fn paper_setup_p1() {
    let dev = paper_deviations(1);
    eprintln!("P_1 deviations: {dev:?}");
    assert!(dev.iter().all(|d| d.abs() < 0.04), "{dev:?}");
}

/// (c) The paper's setup for P_5 (18.7M unknowns, 239M non-zeros: ~12 min and 9 GB with
/// parity-CG on 2 cores; ignored, see docs/pointsource.md).
#[test]
#[ignore]
fn paper_setup_p5() {
    let dev = paper_deviations(5);
    eprintln!("P_5 deviations: {dev:?}");
    assert!(dev.iter().all(|d| d.abs() < 0.04), "{dev:?}");
}

/// Runs `pn solve pointsource <args>` into a fresh directory and returns it.
fn cli(name: &str, args: &[&str]) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("pn-pointsource-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = Command::new(env!("CARGO_BIN_EXE_pn"))
        .args([
            "solve",
            "pointsource",
            "--solver",
            "parity-cg",
            "--threads",
            "1",
        ])
        .args(args)
        .arg("--out")
        .arg(&dir)
        .output()
        .expect("run pn");
    assert!(
        out.status.success(),
        "pn solve pointsource {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    dir
}

fn read_profile(path: &std::path::Path) -> Vec<[f64; 5]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(PROFILE_CSV_HEADER));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3], v[4]]
        })
        .collect()
}

/// `pn solve pointsource` writes the profile files; the columns are what they claim: τ steps
/// by σ_t h along the axis and σ_t h √2 along the diagonal, P_1's exact column equals CDA's,
/// and the solved values are within the coarse grid's discretization error (20%, at 16³
/// σ_t h = 1) of the exact ones for τ ≤ 4 (beyond, the extrapolation closure of the small
/// [0,2]³ domain lifts the tail by up to 60%, which is why the convergence tests use a large
/// absorbing domain). With `--method cda` and a Gaussian source the same holds for
/// the Gaussian-smoothed columns.
#[test]
fn cli_writes_profiles() {
    let dir = cli("p1", &["--order", "1", "--res", "16"]);
    assert!(dir.join("profile.png").exists());
    let axis = read_profile(&dir.join("profile.csv"));
    let diag = read_profile(&dir.join("profile_diagonal.csv"));
    assert_eq!((axis.len(), diag.len()), (7, 7));
    for (k, r) in axis.iter().enumerate() {
        assert!((r[0] - (k + 1) as f64).abs() < 1e-12); // σ_t h = 8 · 2/16 = 1
        assert!((r[2] / r[3] - 1.0).abs() < 1e-12);
        if r[0] <= 4.0 {
            assert!((r[1] / r[2] - 1.0).abs() < 0.2, "{r:?}");
        }
    }
    assert!((diag[0][0] - 2f64.sqrt()).abs() < 1e-12);
    let _ = std::fs::remove_dir_all(&dir);

    let dir = cli(
        "cda",
        &["--method", "cda", "--res", "20", "--source", "gaussian:0.1"],
    );
    let axis = read_profile(&dir.join("profile.csv"));
    for r in &axis {
        assert!((r[2] / r[3] - 1.0).abs() < 1e-12);
        assert!(r[4].is_finite() && r[4] > 0.0);
        if r[0] <= 4.0 {
            assert!((r[1] / r[2] - 1.0).abs() < 0.2, "{r:?}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
