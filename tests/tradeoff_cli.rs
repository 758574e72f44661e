//! `pn tradeoff --quick` through the binary (the CI smoke test of the speed/accuracy trade-off): the CSV
//! has the documented columns, one row per method × resolution × tolerance, every error is
//! finite (FLD has no own reference and leaves that column empty), and the plot exists.
//! Also `pn solve --solver cgnr-mf/lsqr/lsmr` and a bad `--solver` name.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use std::path::PathBuf;

mod support;
use support::{ok, pn};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pn-tradeoff-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn quick_tradeoff_writes_csv_and_plot() {
    let out = dir("quick");
    let o = pn(&["tradeoff", "--quick", "--out", out.to_str().unwrap()]);
    ok(&o);
    let csv = std::fs::read_to_string(out.join("tradeoff.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for col in [
        "method",
        "order",
        "resolution",
        "tolerance",
        "unknowns",
        "iterations",
        "seconds",
        "error_own",
        "own_reference",
        "error_transport",
        "converged",
    ] {
        assert!(header.contains(&col), "missing column {col} in {header:?}");
    }
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // 5 methods × 2 resolutions × 2 tolerances.
    assert_eq!(rows.len(), 20, "{csv}");
    let mut methods: Vec<&str> = rows.iter().map(|r| r[col("method")]).collect();
    methods.dedup();
    assert_eq!(methods, ["cda", "fld", "P1", "P3", "P5"]);
    for r in &rows {
        assert_eq!(r.len(), header.len(), "{r:?}");
        let e: f64 = r[col("error_transport")].parse().unwrap();
        assert!(e.is_finite() && e > 0.0, "{r:?}");
        let own = r[col("error_own")];
        if r[col("method")] == "fld" {
            assert!(own.is_empty(), "{r:?}");
        } else {
            let own: f64 = own.parse().unwrap();
            assert!(own.is_finite() && own >= 0.0, "{r:?}");
        }
        let s: f64 = r[col("seconds")].parse().unwrap();
        assert!(s.is_finite() && s >= 0.0);
        assert_eq!(r[col("converged")], "true", "{r:?}");
    }
    let png = std::fs::metadata(out.join("tradeoff.png")).unwrap();
    assert!(
        png.len() > 10_000,
        "tradeoff.png is only {} bytes",
        png.len()
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn solve_with_matrix_free_and_least_squares_solvers() {
    for solver in ["cgnr-mf", "lsqr", "lsmr", "lsqr-mf"] {
        let out = dir(solver);
        let o = pn(&[
            "solve",
            "checkerboard",
            "--order",
            "1",
            "--res",
            "15",
            "--solver",
            solver,
            "--out",
            out.to_str().unwrap(),
        ]);
        ok(&o);
        let rep: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        let text = rep.to_string();
        assert!(
            text.contains(solver),
            "{solver}: report lacks the solver name"
        );
        let _ = std::fs::remove_dir_all(&out);
    }
    let o = pn(&["solve", "checkerboard", "--solver", "lsqrr"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("lsmr-mf"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}
