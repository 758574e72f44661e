//! PDEs written as text (docs/pde-text.md) through the whole pipeline: the text CDA gives
//! the built-in CDA's fluence, SP_1 = P_1 = CDA on the point source, compiled and
//! interpreted text stencils agree, and bad input gives errors with file, line and column.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod support;

use pn_codegen::text::{parse_pde, TextPde};
use pn_kernels::{cda_kernel, pde_kernel, pn_kernel, Dim, Staggering};
use pn_runtime::pipeline::{solve_problem, Solution};
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::{SolverKind, SolverOptions};
use pn_stencil::{InterpretedKernel, StencilKernel};
use std::path::Path;
use support::{ok, pn, rel_diff, work_dir};

fn pde(name: &str) -> TextPde {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("pdes")
        .join(name);
    parse_pde(&std::fs::read_to_string(path).unwrap(), &[]).unwrap()
}

fn opts(tol: f64) -> SolverOptions {
    SolverOptions {
        tol,
        max_iter: 100_000,
        ..Default::default()
    }
}

fn solve(
    scene: &str,
    res: usize,
    kernel: &dyn StencilKernel,
    solver: SolverKind,
    tol: f64,
) -> Solution {
    let s = builtin(
        scene,
        &BuiltinOptions {
            res: Some(vec![res]),
            ..Default::default()
        },
    )
    .unwrap();
    let sol = solve_problem(&s.problem, kernel, solver, &opts(tol)).unwrap();
    assert!(sol.stats.converged(), "{scene}: {:?}", sol.stats.status);
    sol
}

#[test]
fn cda_from_text_gives_the_built_in_fluence() {
    let text = pde("cda.pde");
    for (scene, res, dim) in [
        ("pointsource", 24, Dim::Three),
        ("checkerboard", 35, Dim::Two),
    ] {
        let built_in = cda_kernel(dim).unwrap();
        let from_text = pde_kernel(&text, dim).unwrap();
        // build.rs compiled pdes/cda.pde: the text's IR has the fingerprint of the compiled one.
        assert!(from_text.compiled, "{scene}");
        let interpreted = InterpretedKernel::new(text.ir(dim).unwrap());
        let a = solve(
            scene,
            res,
            built_in.kernel.as_ref(),
            SolverKind::ParityCg,
            1e-12,
        );
        let b = solve(
            scene,
            res,
            from_text.kernel.as_ref(),
            SolverKind::ParityCg,
            1e-12,
        );
        let c = solve(scene, res, &interpreted, SolverKind::ParityCg, 1e-12);
        // Same stencil, same solver, same iteration: equal up to the order of floating-point
        // operations in the generated vs interpreted weights (1e-12 is the bound).
        let (ab, ac) = (rel_diff(&b.l00(), &a.l00()), rel_diff(&c.l00(), &a.l00()));
        eprintln!(
            "{scene}: text-compiled vs built-in {ab:.2e}, text-interpreted vs built-in {ac:.2e}"
        );
        assert!(ab <= 1e-12 && ac <= 1e-12, "{scene}: {ab:e} {ac:e}");
        assert_eq!(a.stats.iterations, b.stats.iterations);
    }
}

#[test]
fn sp1_equals_p1_equals_cda_on_the_point_source() {
    let n = 24;
    let tol = 1e-12;
    let cda = solve(
        "pointsource",
        n,
        cda_kernel(Dim::Three).unwrap().kernel.as_ref(),
        SolverKind::ParityCg,
        tol,
    );
    let sp1 = solve(
        "pointsource",
        n,
        pde_kernel(&pde("sp1.pde"), Dim::Three)
            .unwrap()
            .kernel
            .as_ref(),
        SolverKind::ParityCg,
        tol,
    );
    let p1k = pn_kernel(1, Dim::Three, Staggering::Staggered).unwrap();
    let p1 = solve(
        "pointsource",
        n,
        p1k.kernel.as_ref(),
        SolverKind::ParityCg,
        tol,
    );
    // The three are one discrete system: P_1's flux on the faces, eliminated, is CDA's
    // −D∇φ with D = 1/(3σ_tr) at the face; SP_1 spells σ_a as σ_t − σ_s λ_0p_0. What is
    // left is the solvers' tolerance (1e-12 relative residual; the point source's condition
    // number at 24³ is below 1e3, so 1e-9 in the solution).
    let d_sp1 = rel_diff(&sp1.l00(), &cda.l00());
    let d_p1 = rel_diff(&p1.l00(), &cda.l00());
    eprintln!("SP_1 vs CDA {d_sp1:.2e}, P_1 vs CDA {d_p1:.2e}");
    assert!(d_sp1 < 1e-9 && d_p1 < 1e-9, "{d_sp1:e} {d_p1:e}");
}

#[test]
fn pn_solve_with_a_pde_file_and_its_errors() {
    let dir = work_dir("pde-text-cli");
    std::fs::create_dir_all(&dir).unwrap();
    let sp3 = Path::new(env!("CARGO_MANIFEST_DIR")).join("pdes/sp3.pde");
    let out = dir.join("sp3");
    let o = pn(&[
        "solve",
        "pointsource",
        "--res",
        "16",
        "--pde",
        sp3.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
    ]);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("PDE pde_sp3_3d"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["method"], "pde");
    assert_eq!(report["stencil"], "pde_sp3_3d");
    assert_eq!(report["converged"], true);

    let bad = dir.join("bad.pde");
    let cases: &[(&str, &[&str], &str)] = &[
        (
            "unknown u = L(0,0)\nequation u: -lap(u) + sigma_a*u = Q(0,0) +\n",
            &[],
            "bad.pde:3:1: expected an expression",
        ),
        (
            "unknown u = L(0,0)\nequation u: -lap(w) + sigma_a*u = Q(0,0)\n",
            &[],
            "bad.pde:2:18: unknown symbol 'w'",
        ),
        (
            "unknown u = L(0,0)\nunknown v\nequation u: -lap(u) + sigma_a*u = Q(0,0)\n",
            &[],
            "bad.pde:2:1: the system is not square",
        ),
        (
            "param s = 1\nunknown u = L(0,0)\nequation u: -lap(u) + s*sigma_a*u = Q(0,0)\n",
            &["--pde-param", "t=2"],
            "no parameter 't'",
        ),
        (
            "param s = 1\nunknown u = L(0,0)\nequation u: -lap(u) + s*sigma_a*u = Q(0,0)\n",
            &["--pde-param", "s"],
            "expected NAME=VALUE",
        ),
    ];
    for (src, extra, want) in cases {
        std::fs::write(&bad, src).unwrap();
        let mut args = vec![
            "solve",
            "pointsource",
            "--res",
            "8",
            "--pde",
            bad.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = pn(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && stderr.contains(want),
            "want {want:?}, got {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    let o = pn(&["solve", "pointsource", "--pde", "no/such.pde"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && stderr.contains("reading the PDE file no/such.pde"),
        "{stderr}"
    );
    let o = pn(&[
        "solve",
        "pointsource",
        "--pde",
        sp3.to_str().unwrap(),
        "--method",
        "cda",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && stderr.contains("--pde replaces --method"),
        "{stderr}"
    );
}

#[test]
fn pn_stencil_prints_a_pde_file() {
    let sp3 = Path::new(env!("CARGO_MANIFEST_DIR")).join("pdes/sp3.pde");
    let o = pn(&["stencil", "--pde", sp3.to_str().unwrap(), "--dim", "2"]);
    ok(&o);
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(
        s.contains("unknowns phi0 = L(0, 0), phi2 (auxiliary"),
        "{s}"
    );
    assert!(
        s.contains("stencil pde_sp3_2d (2D, unknowns per cell: 2)"),
        "{s}"
    );
    // The PDE's own Marshak conditions: 1/2 φ_0 + 5/8 φ_2 + … and −1/8 φ_0 + 5/8 φ_2 + ….
    assert!(s.contains("boundary marshak conditions"), "{s}");
    assert!(
        s.contains("at L_0^0: (0.5)*L_0^0 + (0.625)*") && s.contains(": (-0.125)*L_0^0 + (0.625)*"),
        "{s}"
    );
    let o = pn(&["stencil", "--pde", sp3.to_str().unwrap(), "--json"]);
    ok(&o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["name"], "pde_sp3_3d");
    assert_eq!(v["rows"].as_array().unwrap().len(), 2);
    let b = &v["boundary"];
    assert_eq!(b["kind"], "marshak");
    assert_eq!(b["conditions"].as_array().unwrap().len(), 2);
    assert_eq!(b["conditions"][0]["value"][1]["weight"], "0.625");
}

/// `pn render --pde` hands the PDE every first-scatter band it reads: filtered P_1 with a zero
/// filter is P_1, so on a forward-scattering scene (the cumulus, HG g = 0.7) its image equals
/// `--method pn --order 1`'s bit for bit — with the isotropic source alone it was 37 % darker.
/// (Text PDEs carry no delta-M truncation, so the P_1 render runs without it.)
#[test]
fn a_text_pde_renders_with_the_anisotropic_first_scatter_source() {
    use pn_formats::read_exr_rgb;
    let d = work_dir("pde_render_bands");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join("scenes/cumulus.toml");
    let fpn = root.join("pdes/fpn.pde");
    let common = [
        "--solve-res",
        "8",
        "--set",
        "camera.width=32",
        "--set",
        "camera.height=32",
        "--threads",
        "1",
    ];
    let (a, b) = (d.join("p1"), d.join("fp1"));
    let render = |method: &[&str], out: &Path| {
        let mut args = vec!["render", scene.to_str().unwrap()];
        args.extend(method);
        args.extend(common);
        args.extend(["--out", out.to_str().unwrap()]);
        ok(&pn(&args));
    };
    render(
        &[
            "--method",
            "pn",
            "--order",
            "1",
            "--set",
            "solve.delta_m=false",
        ],
        &a,
    );
    render(
        &[
            "--pde",
            fpn.to_str().unwrap(),
            "--pde-param",
            "N=1",
            "--pde-param",
            "f_eff=0",
        ],
        &b,
    );
    let read = |p: &Path| read_exr_rgb(&p.join("image.exr")).unwrap().2;
    let (ia, ib) = (read(&a), read(&b));
    assert!(ia[0].iter().any(|v| *v > 0.0));
    assert_eq!(ia, ib);
}
