//! `mpirun -np K pn solve … --distributed` (issue 51; built with `--features distributed`,
//! run by `.ci/run` with OpenMPI): the solution on 2–4 processes equals one process to 1e-10
//! relative with the iteration count within ±1, the distributed solve equals the one-process
//! `pn solve`, StaRMAP's checkerboard and the 3D lattice check hold on 4 processes, and bad
//! requests end every process with the cause.
#![cfg(feature = "distributed")]
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod support;

use pn_formats::read_npy;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use support::{ok, pn, rel_diff, starmap_reference, work_dir};

fn mpirun(ranks: usize, args: &[&str]) -> Output {
    Command::new("timeout")
        .args([
            "300",
            "mpirun",
            "--oversubscribe",
            "-np",
            &ranks.to_string(),
        ])
        .arg(env!("CARGO_BIN_EXE_pn"))
        .args(args)
        .output()
        .expect("mpirun (openmpi-bin) must be installed for the distributed feature's tests")
}

/// Moments, fluence and report of `pn solve <args> --distributed` on `ranks` processes.
fn solve(ranks: usize, name: &str, args: &[&str]) -> (Vec<f64>, Vec<f64>, serde_json::Value) {
    let dir = work_dir(&format!("dist-{name}-{ranks}"));
    let mut all: Vec<&str> = vec!["solve"];
    all.extend(args);
    let d = dir.to_str().unwrap();
    all.extend(["--distributed", "--threads", "1", "--out", d]);
    let out = mpirun(ranks, &all);
    assert!(
        out.status.success(),
        "{ranks} processes {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    read_outputs(&dir)
}

fn read_outputs(dir: &Path) -> (Vec<f64>, Vec<f64>, serde_json::Value) {
    let m = read_npy(&dir.join("moments.npy")).unwrap().data;
    let f = read_npy(&dir.join("fluence.npy")).unwrap().data;
    let r =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    (m, f, r)
}

/// Solves on 1–4 processes with `pc` and compares each with one process: 1e-10 relative
/// (with Jacobi the runs differ only in the order of the Krylov method's global sums; the
/// multigrid's aggregation is geometric, the same on any split, and only its coarse
/// operators' sums and eigenvalue estimates see the split), iterations within ±1.
fn parity(name: &str, args: &[&str], pc: &str) -> (Vec<f64>, serde_json::Value) {
    let mut a = args.to_vec();
    a.extend(["--pc", pc, "--tol", "1e-12"]);
    let (m1, _, r1) = solve(1, name, &a);
    let it1 = r1["iterations"].as_i64().unwrap();
    for ranks in 2..=4 {
        let (m, _, r) = solve(ranks, name, &a);
        let d = rel_diff(&m, &m1);
        let it = r["iterations"].as_i64().unwrap();
        eprintln!(
            "{name}: {ranks} processes {:?}: diff {d:.2e}, {it} iterations (1: {it1})",
            r["distributed"]["procs"]
        );
        assert!(
            d <= 1e-10,
            "{name}: {ranks} processes differ from one by {d:.3e}"
        );
        assert!(
            (it - it1).abs() <= 1,
            "{name}: {it} iterations on {ranks}, {it1} on one"
        );
        assert_eq!(r["distributed"]["processes"], ranks);
        // Every process reports the global reductions it took part in (about two per
        // GMRES or CG iteration).
        let red = r["distributed"]["ranks"][0]["reductions"].as_i64().unwrap();
        assert!(
            red >= it,
            "{ranks} processes: {red} reductions for {it} iterations"
        );
    }
    (m1, r1)
}

/// The one-process `pn solve` at the same tolerance.
fn serial(name: &str, args: &[&str]) -> Vec<f64> {
    let dir = work_dir(&format!("serial-{name}"));
    let mut all = vec!["solve"];
    all.extend(args);
    all.extend(["--tol", "1e-12", "--out", dir.to_str().unwrap()]);
    ok(&pn(&all));
    read_outputs(&dir).0
}

#[test]
fn pointsource_on_1_to_4_processes() {
    let args = ["pointsource", "--order", "3", "--res", "20"];
    parity("pointsource-mg", &args, "mg");
    let (m, r) = parity("pointsource", &args, "jacobi");
    assert_eq!(r["converged"], true);
    // Against the one-process parity solver: both at 1e-12, so the solutions agree to the
    // conditioning times that (1e-9 leaves three orders of margin over the observed 1e-11).
    let d = rel_diff(&m, &serial("pointsource", &args));
    assert!(d <= 1e-9, "distributed vs pn solve: {d:.3e}");
}

#[test]
fn checkerboard3d_marshak_on_1_to_4_processes() {
    let args = [
        "checkerboard3d",
        "--order",
        "1",
        "--res",
        "21",
        "--bc",
        "marshak",
    ];
    let (m, _) = parity("checkerboard3d", &args, "jacobi");
    let d = rel_diff(&m, &serial("checkerboard3d", &args));
    assert!(d <= 1e-9, "distributed vs pn solve: {d:.3e}");
}

/// CDA (no parity structure: `A` split as it stands) and the SP_3 text PDE equal the
/// one-process solve.
#[test]
fn cda_and_a_text_pde_on_three_processes() {
    let sp3 = concat!(env!("CARGO_MANIFEST_DIR"), "/pdes/sp3.pde");
    for (name, args) in [
        ("cda", vec!["checkerboard", "--method", "cda"]),
        ("sp3", vec!["checkerboard", "--pde", sp3]),
    ] {
        let mut a = args.clone();
        a.extend(["--tol", "1e-12"]);
        let (m, _, r) = solve(3, name, &a);
        assert_eq!(r["distributed"]["processes"], 3);
        let d = rel_diff(&m, &serial(name, &args));
        assert!(d <= 1e-9, "{name}: distributed vs pn solve: {d:.3e}");
    }
}

/// `pn render --distributed`: every process takes part in the render's solve, process 0
/// renders; the image equals the one-process render's to the solver tolerance (1e-8 here:
/// 1e-6 of the image's largest value leaves two orders of margin).
#[test]
fn render_on_two_processes_equals_one() {
    let args = [
        "render",
        "sphere",
        "--order",
        "3",
        "--solve-res",
        "16",
        "--set",
        "camera.width=48",
        "--set",
        "camera.height=48",
        "--set",
        "solve.tolerance=1e-8",
    ];
    let one = work_dir("render-one");
    let two = work_dir("render-two");
    let mut a = args.to_vec();
    a.extend(["--out", one.to_str().unwrap()]);
    ok(&pn(&a));
    let mut a = args.to_vec();
    a.extend([
        "--distributed",
        "--threads",
        "1",
        "--out",
        two.to_str().unwrap(),
    ]);
    ok(&mpirun(2, &a));
    let (w1, h1, i1) = pn_formats::read_exr_gray(&one.join("image.exr")).unwrap();
    let (w2, h2, i2) = pn_formats::read_exr_gray(&two.join("image.exr")).unwrap();
    assert_eq!((w1, h1), (w2, h2));
    let a: Vec<f64> = i2.iter().map(|&v| v as f64).collect();
    let b: Vec<f64> = i1.iter().map(|&v| v as f64).collect();
    assert!(b.iter().any(|&v| v > 0.0));
    let d = rel_diff(&a, &b);
    assert!(
        d <= 1e-6,
        "distributed render differs by {d:.3e} of the maximum"
    );
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(two.join("report.json")).unwrap()).unwrap();
    assert!(
        rep.to_string().contains("petsc-"),
        "the report names the distributed solver"
    );
}

/// An even order keeps the odd moments; on 3 processes a coarse row of the multigrid's
/// first operator lacked its diagonal entry until the diagonal was allowed to add it. Where
/// the absorption vanishes the even moments are kept instead.
#[test]
fn even_order_on_three_processes() {
    let args = ["pointsource", "--order", "4", "--res", "18"];
    let mut a = args.to_vec();
    a.extend(["--tol", "1e-12"]);
    let (m, _, _) = solve(3, "p4", &a);
    let d = rel_diff(&m, &serial("p4", &args));
    assert!(d <= 1e-9, "P_4 on 3 processes vs pn solve: {d:.3e}");
    // The checkerboard's pure scatterer (zero absorption) cannot eliminate the even moments:
    // every process keeps them instead, as pn solve does.
    let args = ["checkerboard", "--order", "2"];
    let mut a = args.to_vec();
    a.extend(["--tol", "1e-12"]);
    let (m, _, _) = solve(3, "c2", &a);
    let d = rel_diff(&m, &serial("c2", &args));
    assert!(
        d <= 1e-9,
        "checkerboard P_2 on 3 processes vs pn solve: {d:.3e}"
    );
}

/// StaRMAP's checkerboard (P_1, 71², tests/checkerboard.rs's bound) on 2×2 boxes with the
/// default preconditioner (GAMG).
#[test]
fn starmap_checkerboard_on_four_processes() {
    let (_, f, r) = solve(4, "starmap", &["checkerboard", "--order", "1"]);
    assert_eq!(r["distributed"]["procs"], serde_json::json!([2, 2, 1]));
    let d = rel_diff(&f, &starmap_reference("starmap_p1_n71.csv"));
    assert!(
        d <= 1e-6,
        "P1 on 4 processes differs from StaRMAP by {d:.3e} of max"
    );
}

/// The 3D lattice check of tests/checkerboard.rs (31³: mirror symmetry in x and z, power
/// balance) on 4 processes.
#[test]
fn lattice_3d_on_four_processes() {
    let (_, f, r) = solve(
        4,
        "lattice",
        &["checkerboard3d", "--order", "1", "--res", "31"],
    );
    let n = 31;
    let at = |i: usize, j: usize, k: usize| f[(i * n + j) * n + k];
    let max = f.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let mut worst = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                worst = worst
                    .max((at(i, j, k) - at(n - 1 - i, j, k)).abs())
                    .max((at(i, j, k) - at(i, j, n - 1 - k)).abs());
            }
        }
    }
    assert!(worst / max < 1e-8, "mirror asymmetry {:.3e}", worst / max);
    let imbalance = r["energy_balance"]["relative_imbalance"].as_f64().unwrap();
    assert!(imbalance < 1e-8, "energy imbalance {imbalance:.3e}");
}

fn stderr_of(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn refuses_splits_that_do_not_fit() {
    let dir = work_dir("dist-refused");
    let d = dir.to_str().unwrap();
    let base = [
        "solve",
        "pointsource",
        "--order",
        "1",
        "--res",
        "8",
        "--distributed",
        "--out",
        d,
    ];
    // `base` plus `extra` on `ranks` processes (0: without mpirun) fails, naming `want`.
    let refused = |ranks: usize, extra: &[&str], want: &str| {
        let mut a = base.to_vec();
        a.extend(extra);
        let out = if ranks == 0 {
            Command::new(env!("CARGO_BIN_EXE_pn"))
                .args(&a)
                .output()
                .unwrap()
        } else {
            mpirun(ranks, &a)
        };
        assert!(!out.status.success(), "{a:?} succeeded");
        assert!(stderr_of(&out).contains(want), "{a:?}: {}", stderr_of(&out));
        out
    };
    refused(
        4,
        &["--procs", "2x1x1"],
        "makes 2 boxes but 4 processes run",
    );
    refused(5, &["--procs", "1x1x5"], "at most 4 processes along z");
    // Without a launcher: the command to start it with.
    let out = refused(0, &[], "needs an MPI launcher");
    assert_eq!(out.status.code(), Some(1));
    refused(2, &["--method", "fld"], "FLD is nonlinear");
    assert!(!dir.exists() || std::fs::read_dir(&dir).unwrap().next().is_none());
}

/// Process 0 fails alone (its output file is blocked by a folder, found only when it moves
/// the files in) while process 1 waits for it: both end, with the message and a non-zero
/// status, long before the 300 s limit.
#[test]
fn an_error_on_one_process_ends_every_process() {
    let dir: PathBuf = work_dir("dist-one-fails");
    std::fs::create_dir_all(dir.join("fluence.npy").join("blocker")).unwrap();
    let start = std::time::Instant::now();
    let out = mpirun(
        2,
        &[
            "solve",
            "pointsource",
            "--order",
            "1",
            "--res",
            "10",
            "--distributed",
            "--out",
            dir.to_str().unwrap(),
        ],
    );
    let seconds = start.elapsed().as_secs_f64();
    assert!(!out.status.success());
    assert_ne!(out.status.code(), Some(124), "timed out: a process hung");
    let err = stderr_of(&out);
    assert!(err.contains("error (process 0 of 2)"), "{err}");
    assert!(err.contains("fluence.npy"), "{err}");
    assert!(seconds < 120.0, "took {seconds:.0} s");
}
