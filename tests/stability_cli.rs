//! Bad input at the command line: the memory estimate and `--max-memory`, the automatic
//! σ_t threshold, and a clear error (never a panic) for every bad flag value.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_formats::encode_npy;
use std::path::PathBuf;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pn-stability-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn pn(args: &[&str], out: &std::path::Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pn"))
        .arg("solve")
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// Runs a command that must fail cleanly; returns its stderr.
fn fails(args: &[&str]) -> String {
    let d = dir("fails");
    let o = pn(args, &d);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!o.status.success(), "{args:?} succeeded");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    err
}

/// An absurd resolution is refused before anything is allocated, with the estimate.
#[test]
fn absurd_resolution_is_refused_quickly() {
    for args in [
        &["pointsource", "--res", "100000"][..],
        &["checkerboard", "--res", "100000"],
        &["pointsource", "--res", "18446744073709551615"],
        &["checkerboard3d", "--res", "4096", "--order", "5"],
        &["pointsource", "--method", "fld", "--res", "100000"],
    ] {
        let t = Instant::now();
        let e = fails(args);
        // Allocating even the unknown vector of 4e15 values would take far longer (or be
        // killed); the check itself is a handful of multiplications.
        assert!(
            t.elapsed() < Duration::from_secs(5),
            "{args:?} took {:?}",
            t.elapsed()
        );
        assert!(
            e.contains("unknowns") && e.contains("memory limit") && e.contains("--max-memory"),
            "{args:?}: {e}"
        );
    }
    // 100000³ cells of P_1 (4 moments, 1 centred + 3 face-staggered): 4e15 + 3e10 unknowns.
    let e = fails(&["pointsource", "--res", "100000"]);
    assert!(e.contains("4000030000000000 unknowns"), "{e}");
}

/// `--max-memory` below the estimate refuses a small problem; above it, it runs.
#[test]
fn max_memory_flag() {
    let e = fails(&["pointsource", "--res", "8", "--max-memory", "1K"]);
    assert!(e.contains("1.00 KiB"), "{e}");
    let d = dir("maxmem");
    let o = pn(&["pointsource", "--res", "8", "--max-memory", "1G"], &d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for bad in ["abc", "0", "-5M", "1e400", "12Q"] {
        let flag = format!("--max-memory={bad}");
        let e = fails(&["pointsource", "--res", "4", &flag]);
        assert!(e.contains("max-memory"), "{bad}: {e}");
    }
}

/// A cloud with vacuum around it: the threshold is chosen automatically (1e-3 × max σ_t),
/// printed once, and written to report.json; an explicit one wins.
#[test]
fn automatic_sigma_t_min() {
    let d = dir("auto");
    // σ_t = 0 in the first x-slab of a 4×4×4 grid, 5 elsewhere (max 5 → threshold 5e-3).
    let n = 4;
    let data: Vec<f64> = (0..n * n * n)
        .map(|i| if i / (n * n) == 0 { 0.0 } else { 5.0 })
        .collect();
    std::fs::write(d.join("s.npy"), encode_npy(&[n, n, n], &data).unwrap()).unwrap();
    let scene = d.join("cloud.toml");
    std::fs::write(
        &scene,
        "sigma_t = { file = \"s.npy\" }\nalbedo = 0.5\nboundary = \"dirichlet\"\n\
         [[source]]\nl = 0\nm = 0\nvalue = 1.0\n",
    )
    .unwrap();
    let s = scene.to_str().unwrap();
    let out = d.join("out");
    let o = pn(&[s, "--order", "1"], &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert_eq!(err.matches("vacuum").count(), 1, "{err}");
    assert!(err.contains("5.000e-3"), "{err}");
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let t = rep["sigma_t_min"].as_f64().unwrap();
    assert!((t - 5e-3).abs() < 1e-15, "{t}");
    assert_eq!(rep["converged"], true);
    // An explicit threshold is used as given, without the note.
    let o = pn(&[s, "--order", "1", "--sigma-t-min", "0.25"], &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && !err.contains("vacuum"), "{err}");
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(rep["sigma_t_min"], 0.25);
}

/// Every bad flag value is an error that names the flag or the quantity, not a panic.
#[test]
fn bad_flags_are_errors() {
    let cases: &[(&[&str], &str)] = &[
        (&["--threads", "0"], "--threads"),
        (&["--order", "0"], "order"),
        (&["--order", "61"], "order"),
        (&["--sigma-t-min", "nan"], "--sigma-t-min"),
        (&["--sigma-t-min", "0"], "--sigma-t-min"),
        (&["--sigma-t-min=-1"], "--sigma-t-min"),
        (&["--g", "1"], "--g"),
        (&["--g", "nan"], "--g"),
        (&["--half-width", "0"], "--half-width"),
        (&["--half-width", "1e308"], "domain"),
        (&["--source", "gaussian:-1"], "--source"),
        (&["--source", "gaussian:x"], "--source"),
        (&["--tol", "0"], "--tol"),
        (&["--tol", "nan"], "--tol"),
        (&["--max-iter", "0"], "--max-iter"),
        (&["--sigma-t", "inf"], "--sigma-t"),
        (&["--sigma-t", "1e300"], "rescale"),
        (&["--albedo=-0.1"], "--albedo"),
        (&["--albedo", "1.5"], "albedo"),
        (&["--albedo", "1"], "singular"),
        (&["--dim", "4"], "--dim"),
        (&["--bc", "foo"], "--bc"),
        (&["--solver", "foo"], "--solver"),
        (&["--res", "3,0,2"], "resolution"),
        (&["--res", "4,4,4,4"], "--res"),
        (&["--method", "x"], "--method"),
        (&["--method", "cda", "--order", "3"], "--order"),
    ];
    for (flags, word) in cases {
        let mut args = vec!["pointsource"];
        if !flags.contains(&"--res") {
            args.extend(["--res", "3"]);
        }
        args.extend_from_slice(flags);
        let e = fails(&args);
        assert!(e.contains(word), "{flags:?}: expected {word:?} in {e}");
    }
}
