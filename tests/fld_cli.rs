//! `pn solve --method fld`: end to end on the point source (files, report, L_0^0
//! normalisation), the Picard route against the Gauss–Seidel route on a sphere in vacuum
//! given as voxel data, and the errors of bad FLD input.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_formats::{encode_npy, read_npy};
use std::path::{Path, PathBuf};

mod support;
use support::pn;

/// A fresh scratch directory, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Self {
        let d = std::env::temp_dir().join(format!("pn-fld-cli-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Self(d)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Runs `pn solve` and returns (fluence.npy data, report).
fn solve_ok(args: &[&str], out: &Path) -> (Vec<f64>, serde_json::Value) {
    let mut all = vec!["solve"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--out", out.to_str().unwrap()]);
    let o = pn(&all);
    assert!(
        o.status.success(),
        "pn {all:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let f = read_npy(&out.join("fluence.npy")).unwrap().data;
    let rep =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    (f, rep)
}

fn fails(args: &[&str]) -> String {
    let mut all = vec!["solve"];
    all.extend_from_slice(args);
    let o = pn(&all);
    assert!(!o.status.success(), "pn {all:?} should fail");
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// `pn solve pointsource --method fld` writes the P_N outputs plus the Figure-5 profile, with
/// the FLD report entries.
#[test]
fn pointsource_fld_end_to_end() {
    let d = Scratch::new("ps");
    let out = d.0.join("o");
    let (f, rep) = solve_ok(
        &[
            "pointsource",
            "--method",
            "fld",
            "--res",
            "15",
            "--sigma-t",
            "2",
            "--tol",
            "1e-6",
            "--fld-all-limiters",
        ],
        &out,
    );
    for name in [
        "fluence.npy",
        "moments.npy",
        "fluence.png",
        "report.json",
        "fld_profile.png",
        "fld_profile.csv",
    ] {
        let meta = std::fs::metadata(out.join(name)).unwrap();
        assert!(meta.len() > 0, "{name} is empty");
    }
    assert_eq!(f.len(), 15 * 15 * 15);
    assert_eq!(rep["method"], "fld");
    let fld = &rep["fld"];
    // Picard is the default route; ω belongs to Gauss–Seidel only.
    assert_eq!(fld["route"], "picard");
    assert_eq!(fld["limiter"], "lp");
    assert!(fld["omega"].is_null());
    assert_eq!(fld["converged"], true);
    assert!(fld["iterations"].as_u64().unwrap() > 0);
    assert!(fld["residual"].as_f64().unwrap() < 1e-6);
    // σ_ε defaults to 1e-3/L with L = 2 the domain edge.
    assert!((fld["sigma_eps"].as_f64().unwrap() - 5e-4).abs() < 1e-15);
    assert_eq!(rep["iterations"], fld["iterations"]);
    // The profile has every limiter and the references, one row per cell beyond the source
    // up to the last interior cell (source at 7, cells 8..=13).
    let csv = std::fs::read_to_string(out.join("fld_profile.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    for col in [
        "tau",
        "cda_discrete",
        "fld_lp",
        "fld_sum",
        "fld_max",
        "fld_kershaw",
        "fld_larsen2",
        "p_5_exact",
        "grosjean",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "{col} missing: {header}"
        );
    }
    assert_eq!(lines.count(), 6);
    // The maximum is in the source cell n/2 = 7.
    let max = f.iter().cloned().fold(0.0, f64::max);
    assert_eq!(max, f[(7 * 15 + 7) * 15 + 7]);
}

/// Without `--fld-all-limiters` the point-source profile costs no extra solve: it holds the
/// run's own limiter and the closed forms only.
#[test]
fn pointsource_fld_profile_shows_only_the_own_limiter_by_default() {
    let d = Scratch::new("ps-own");
    let out = d.0.join("o");
    let args = [
        "pointsource",
        "--method",
        "fld",
        "--limiter",
        "kershaw",
        "--res",
        "15",
        "--sigma-t",
        "2",
        "--tol",
        "1e-6",
    ];
    solve_ok(&args, &out);
    let csv = std::fs::read_to_string(out.join("fld_profile.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for col in [
        "tau",
        "fld_kershaw",
        "p_5_exact",
        "cda_closed_form",
        "grosjean",
    ] {
        assert!(header.contains(&col), "{col} missing: {header:?}");
    }
    for col in [
        "cda_discrete",
        "fld_lp",
        "fld_sum",
        "fld_max",
        "fld_larsen2",
    ] {
        assert!(
            !header.contains(&col),
            "{col} solved without the flag: {header:?}"
        );
    }
}

/// fluence.npy holds L_0^0, as for `--method cda`: with the CDA limiter in a strongly absorbing
/// medium (the fluence decays by e^{−30} before the boundary, so the two boundary treatments do
/// not matter) the FLD output equals the CDA pipeline's output. A fluence written as φ would be
/// off by √(4π) ≈ 3.5.
#[test]
fn fld_output_is_l00_like_cda() {
    let d = Scratch::new("norm");
    let common = [
        "pointsource",
        "--res",
        "15",
        "--sigma-t",
        "20",
        "--albedo",
        "0.1",
        "--tol",
        "1e-10",
    ];
    let mut fld_args = common.to_vec();
    fld_args.extend_from_slice(&["--method", "fld", "--limiter", "cda"]);
    let (f_fld, _) = solve_ok(&fld_args, &d.0.join("fld"));
    let mut cda_args = common.to_vec();
    cda_args.extend_from_slice(&["--method", "cda", "--bc", "dirichlet"]);
    let (f_cda, _) = solve_ok(&cda_args, &d.0.join("cda"));
    let max = f_cda.iter().cloned().fold(0.0, f64::max);
    let n = 15;
    // Cells within 3 of the source: both solves converged to 1e-10 on the same 7-point
    // operator; 1e-6 leaves room for the residual tolerance times the conditioning.
    for i in 4..=10 {
        for j in 4..=10 {
            for k in 4..=10 {
                let c = (i * n + j) * n + k;
                assert!(
                    (f_fld[c] - f_cda[c]).abs() <= 1e-6 * max,
                    "cell ({i},{j},{k}): fld {} cda {}",
                    f_fld[c],
                    f_cda[c]
                );
            }
        }
    }
}

/// A sphere of σ_t = 10 (albedo 0.9) in vacuum as voxel data, with a source in its centre.
fn sphere_scene(d: &Path, n: usize) -> PathBuf {
    let mut sigma = vec![0.0; n * n * n];
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let x = [i, j, k].map(|v| (v as f64 + 0.5) / n as f64 - 0.5);
                if x.iter().map(|v| v * v).sum::<f64>() < 0.25 * 0.25 {
                    sigma[(i * n + j) * n + k] = 10.0;
                }
            }
        }
    }
    std::fs::write(d.join("sigma.npy"), encode_npy(&[n, n, n], &sigma).unwrap()).unwrap();
    let p = d.join("sphere.toml");
    std::fs::write(
        &p,
        format!(
            "dim = 3\nresolution = [{n}, {n}, {n}]\nsigma_t = {{ file = \"sigma.npy\" }}\n\
             albedo = 0.9\n[[source]]\nl = 0\nm = 0\nvalue = 1.0\n\
             box_min = [0.4, 0.4, 0.4]\nbox_max = [0.6, 0.6, 0.6]\n"
        ),
    )
    .unwrap();
    p
}

/// Both routes through the CLI agree on the sphere in vacuum (σ_ε = 1e-3/L by default).
#[test]
fn picard_and_gs_routes_agree_via_cli() {
    let d = Scratch::new("sphere");
    let scene = sphere_scene(&d.0, 16);
    let s = scene.to_str().unwrap();
    let (f_gs, rep_gs) = solve_ok(
        &[s, "--method", "fld", "--fld-solver", "gs", "--tol", "1e-9"],
        &d.0.join("gs"),
    );
    assert_eq!(rep_gs["fld"]["route"], "gs");
    assert_eq!(rep_gs["fld"]["omega"], 1.5);
    let (f_pc, rep_pc) = solve_ok(
        &[
            s,
            "--method",
            "fld",
            "--fld-solver",
            "picard",
            "--solver",
            "parity-cg",
            "--tol",
            "1e-9",
        ],
        &d.0.join("pc"),
    );
    assert_eq!(rep_pc["fld"]["route"], "picard");
    // parity-cg solves the scalar SPD steps with multigrid-preconditioned CG and says so.
    assert_eq!(rep_pc["fld"]["linear_solver"], "mg-cg");
    assert_eq!(rep_pc["stencil"], "diffusion_3d");
    assert!(rep_pc["fld"]["omega"].is_null());
    let steps = rep_pc["fld"]["iterations"].as_u64().unwrap() as usize;
    assert_eq!(
        rep_pc["fld"]["linear_iterations"].as_array().unwrap().len(),
        steps
    );
    assert_eq!(rep_gs["fld"]["sigma_eps"], 1e-3);
    let max = f_gs.iter().cloned().fold(0.0, f64::max);
    let diff = f_gs
        .iter()
        .zip(&f_pc)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    // Residual ≤ 1e-9 j̄ in both: see pn-runtime/tests/fld_picard.rs for the margin.
    assert!(diff <= 1e-6 * max, "max |Δ| = {diff}, max = {max}");
}

#[test]
fn bad_fld_input_is_rejected() {
    let d = Scratch::new("errors");
    let scene = sphere_scene(&d.0, 8);
    let s = scene.to_str().unwrap();
    let out = d.0.join("o");
    let o = out.to_str().unwrap();
    let cases: [(&[&str], &str); 13] = [
        (
            &[s, "--method", "fld", "--limiter", "bogus"],
            "unknown flux limiter",
        ),
        (&[s, "--method", "fld", "--omega", "2"], "(0, 2)"),
        (&[s, "--method", "fld", "--omega", "0"], "(0, 2)"),
        (&[s, "--method", "fld", "--omega=-0.5"], "(0, 2)"),
        (&[s, "--method", "fld", "--sigma-eps", "0"], "vacuum"),
        (&[s, "--method", "fld", "--sigma-eps=-1"], "--sigma-eps"),
        (
            &[s, "--method", "pn", "--limiter", "lp"],
            "--method fld only",
        ),
        (
            &[s, "--method", "cda", "--omega", "1.2"],
            "--method fld only",
        ),
        (
            &[
                s,
                "--method",
                "fld",
                "--fld-solver",
                "picard",
                "--omega",
                "1.2",
            ],
            "gs only",
        ),
        (&["pointsource", "--method", "fld", "--dim", "2"], "3D only"),
        (
            &[s, "--method", "fld", "--sigma-t-min", "0.1"],
            "--sigma-eps",
        ),
        (
            &["pointsource", "--method", "pn", "--fld-all-limiters"],
            "--method fld only",
        ),
        (
            &[s, "--method", "fld", "--fld-all-limiters"],
            "pointsource scene only",
        ),
    ];
    for (args, needle) in cases {
        let mut a = args.to_vec();
        a.extend_from_slice(&["--out", o]);
        let err = fails(&a);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    let err = fails(&[s, "--method", "fld", "--fld-solver", "sor", "--out", o]);
    assert!(err.contains("gs") && err.contains("picard"), "{err}");
    // Non-cubic cells.
    let err = fails(&[
        "pointsource",
        "--method",
        "fld",
        "--res",
        "8,8,10",
        "--out",
        o,
    ]);
    assert!(err.contains("cubic"), "{err}");
}

/// Too few iterations: non-zero exit naming the residual, results marked not converged.
#[test]
fn fld_not_converged_is_flagged() {
    let d = Scratch::new("maxiter");
    let out = d.0.join("o");
    let o = pn(&[
        "solve",
        "pointsource",
        "--method",
        "fld",
        "--res",
        "11",
        "--max-iter",
        "3",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("did not converge"), "{err}");
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(rep["converged"], false);
    assert_eq!(rep["fld"]["iterations"], 3);
}
