//! `pn solve` on TOML scenes with voxel data (.npy and .vol) and on the point source.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod support;

use pn_formats::encode_vol;
use pn_formats::{encode_npy, read_npy};
use pn_runtime::field::VoxelGrid;
use std::path::PathBuf;
use std::process::Command;
use support::rel_diff;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pn-solve-scenes-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `pn solve <scene> <args> --out <out>` and returns (fluence, report).
fn solve(
    scene: &std::path::Path,
    args: &[&str],
    out: &std::path::Path,
) -> (Vec<f64>, serde_json::Value) {
    let o = Command::new(env!("CARGO_BIN_EXE_pn"))
        .arg("solve")
        .arg(scene)
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let f = read_npy(&out.join("fluence.npy")).unwrap().data;
    let rep =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    (f, rep)
}

const TAIL: &str = "albedo = 0.8\n[[source]]\nl = 0\nm = 0\nvalue = 1.0\nbox_min = [0.25, 0.25, 0.25]\nbox_max = [0.5, 0.5, 0.5]\n";

/// σ_t varying along x as voxel data: the .npy (x first axis, C order) and the .vol
/// (x fastest) encodings of the same grid give the same answer, and a constant voxel grid
/// gives the same answer as the constant field (averaging a constant is exact).
#[test]
fn voxel_files_agree_with_each_other_and_constants() {
    let d = dir("voxels");
    let n = 6;
    let data: Vec<f64> = (0..n * n * n).map(|i| 1.0 + (i / (n * n)) as f64).collect();
    let g = VoxelGrid::new([n, n, n], [0.0; 3], [1.0; 3], data.clone()).unwrap();
    std::fs::write(d.join("s.vol"), encode_vol(&g)).unwrap();
    std::fs::write(d.join("s.npy"), encode_npy(&[n, n, n], &data).unwrap()).unwrap();
    std::fs::write(
        d.join("c.npy"),
        encode_npy(&[n, n, n], &vec![2.0; n * n * n]).unwrap(),
    )
    .unwrap();
    let scene = |name: &str, sigma: &str| {
        let p = d.join(format!("{name}.toml"));
        std::fs::write(
            &p,
            format!("dim = 3\nresolution = [{n}, {n}, {n}]\nsigma_t = {sigma}\n{TAIL}"),
        )
        .unwrap();
        p
    };
    let args = ["--order", "1", "--tol", "1e-12"];
    let (f_vol, rep) = solve(&scene("vol", "{ file = \"s.vol\" }"), &args, &d.join("o1"));
    let (f_npy, _) = solve(&scene("npy", "{ file = \"s.npy\" }"), &args, &d.join("o2"));
    assert_eq!(rep["field_evaluation"], "voxel-averaged");
    assert!(rel_diff(&f_vol, &f_npy) < 1e-10);
    let (f_cvox, _) = solve(&scene("cvox", "{ file = \"c.npy\" }"), &args, &d.join("o3"));
    let (f_const, rep) = solve(&scene("const", "2.0"), &args, &d.join("o4"));
    assert_eq!(rep["field_evaluation"], "exact");
    assert!(rel_diff(&f_cvox, &f_const) < 1e-10);
    // The x-gradient matters: more extinction at large x lowers the fluence there.
    assert!(rel_diff(&f_vol, &f_const) > 1e-2);
    let _ = std::fs::remove_dir_all(&d);
}

/// The point source (small grid): runs, reports, and the fluence is symmetric about the
/// source cell in x and y and z (the cell n/2 = 5 of 11 is the centre cell).
#[test]
fn pointsource_runs_and_is_symmetric() {
    let d = dir("point");
    let (f, rep) = solve(
        std::path::Path::new("pointsource"),
        &["--order", "1", "--res", "11", "--tol", "1e-12"],
        &d.join("o"),
    );
    assert_eq!(rep["scene"], "pointsource");
    let n = 11;
    let at = |i: usize, j: usize, k: usize| f[(i * n + j) * n + k];
    let max = f.iter().fold(0.0f64, |a, b| a.max(*b));
    assert_eq!(max, at(5, 5, 5));
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let v = at(i, j, k);
                assert!((v - at(n - 1 - i, j, k)).abs() < 1e-9 * max);
                assert!((v - at(j, i, k)).abs() < 1e-9 * max);
                assert!((v - at(k, j, i)).abs() < 1e-9 * max);
            }
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// Too few iterations: non-zero exit with the residual reached, and complete results
/// marked `"converged": false`.
#[test]
fn not_converged_is_flagged() {
    let d = dir("maxiter");
    let out = d.join("o");
    let o = Command::new(env!("CARGO_BIN_EXE_pn"))
        .args([
            "solve",
            "checkerboard",
            "--order",
            "1",
            "--res",
            "15",
            "--max-iter",
            "5",
            "--threads",
            "1",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("not converged") && err.contains("relative residual"),
        "{err}"
    );
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(rep["converged"], false);
    assert_eq!(rep["status"], "max_iterations");
    assert_eq!(rep["iterations"], 5);
    assert_eq!(rep["threads"], 1);
    assert!(rep["final_residual"].as_f64().unwrap() > 1e-10);
    for f in ["fluence.npy", "moments.npy", "fluence.png"] {
        assert!(out.join(f).exists());
    }
    // moments.npy: (nx, ny, (N+1)²) with the vanishing 2D moments (l+m odd) zero.
    let m = read_npy(&out.join("moments.npy")).unwrap();
    assert_eq!(m.shape, vec![15, 15, 4]);
    assert!(
        m.data.iter().skip(2).step_by(4).all(|v| *v == 0.0),
        "L_1^0 must vanish in 2D"
    );
    assert!(m.data.iter().skip(3).step_by(4).any(|v| *v != 0.0));
    let _ = std::fs::remove_dir_all(&d);
}
