//! `pn converge` and `pn solve --error-estimate / --sampling` through the binary.
//!
//! Checkerboard resolutions 18, 36, 72, 144: 7 does not divide them, so no cell face lies on
//! a block face and no staggered position (multiples of 7/(2n)) lands on one either (2n | 7m
//! only for m = 2n, the domain edge); the sub-samples of `--sampling average` sit at odd
//! multiples of 7/(16n) and never on an interface.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_formats::read_npy;
use pn_runtime::convergence::restrict;
use std::path::PathBuf;
use std::process::Output;

mod support;
use support::{ok, pn};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pn-converge-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn fails_with(o: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "expected a failure");
    assert!(err.contains(needle), "stderr lacks {needle:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

fn report(d: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(d.join("report.json")).unwrap()).unwrap()
}

/// The study on the checkerboard, P_1 at 36/72/144: the table's columns are consistent with
/// each other (the order is log2 of the ratio of successive differences; the Richardson
/// estimate is the last difference over 2^p − 1) and the files are written. The values
/// themselves are reported, not prescribed: at these resolutions the absorbers (σ_t = 10,
/// 1–2 mean free paths per cell) are unresolved.
#[test]
fn converge_checkerboard_p1_table_is_consistent() {
    let d = dir("cb");
    let o = pn(&[
        "converge",
        "checkerboard",
        "--order",
        "1",
        "--res",
        "36,72,144",
        "--out",
        d.to_str().unwrap(),
    ]);
    ok(&o);
    assert!(d.join("convergence.png").is_file());
    let csv = std::fs::read_to_string(d.join("convergence.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[2][0], "144");
    let num = |r: usize, c: usize| rows[r][c].parse::<f64>().unwrap();
    // Columns: 3 diff_prev, 4 diff_finest, 5 order_successive, 7 richardson, 8 its order.
    let (d1, d2) = (num(1, 3), num(2, 3));
    assert!(
        d2 < d1,
        "differences must shrink under refinement: {d1} then {d2}"
    );
    let p = num(2, 5);
    // diff_prev is relative to the finer level; the order uses absolute norms, which differ
    // by the ratio of the levels' norms (a few %): 0.15 in p.
    assert!(
        (p - (d1 / d2).log2()).abs() < 0.15,
        "p = {p}, d1/d2 = {}",
        d1 / d2
    );
    let p_used = num(2, 8);
    let expect = if p > 0.5 && p < 4.0 { p } else { 2.0 };
    assert!((p_used - expect).abs() < 1e-3);
    let rich = num(2, 7);
    let want = d2 / (2f64.powf(p_used) - 1.0);
    // CSV values are printed to 7 significant digits and p to 3 decimals.
    assert!((rich / want - 1.0).abs() < 5e-3, "{rich} vs {want}");
    // The finest level has no difference to itself; block columns are filled.
    assert!(rows[2][4].is_empty());
    assert!(!rows[0][9].is_empty());
}

#[test]
fn converge_rejects_bad_resolution_lists() {
    fails_with(
        &pn(&[
            "converge",
            "checkerboard",
            "--order",
            "1",
            "--res",
            "71,100",
        ]),
        "nest",
    );
    fails_with(
        &pn(&["converge", "checkerboard", "--order", "1", "--res", "71"]),
        "at least two resolutions",
    );
    fails_with(
        &pn(&[
            "converge",
            "checkerboard",
            "--order",
            "1",
            "--res",
            "142,71",
        ]),
        "increase",
    );
    fails_with(
        &pn(&[
            "solve",
            "checkerboard",
            "--order",
            "1",
            "--res",
            "71",
            "--error-estimate",
        ]),
        "even",
    );
    fails_with(
        &pn(&["solve", "checkerboard", "--sampling", "median"]),
        "unknown sampling",
    );
}

/// `--error-estimate` at 72: error.npy (36×36) equals (R u_72 − u_36)/(2^p − 1) computed from
/// independent `pn solve` runs at 72 and 36, with the p the report names (observed from
/// 72/36/18, since 72 is divisible by 4). 1e-9 relative: both solves stop at a relative
/// residual of 1e-10 and are deterministic, so the same runs agree to rounding.
#[test]
fn error_estimate_matches_separate_solves() {
    let (d72, d36) = (dir("e72"), dir("e36"));
    let o = pn(&[
        "solve",
        "checkerboard",
        "--order",
        "1",
        "--res",
        "72",
        "--error-estimate",
        "--threads",
        "1",
        "--out",
        d72.to_str().unwrap(),
    ]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("error estimate (Richardson"), "{err}");
    ok(&pn(&[
        "solve",
        "checkerboard",
        "--order",
        "1",
        "--res",
        "36",
        "--threads",
        "1",
        "--out",
        d36.to_str().unwrap(),
    ]));
    let rep = report(&d72);
    let est = &rep["error_estimate"];
    let p = est["order"].as_f64().unwrap();
    assert!(est["order_source"].as_str().unwrap().contains("observed"));
    assert!(est["extra_seconds"].as_f64().unwrap() > 0.0);
    assert_eq!(rep["sampling"], "exact");
    let e = read_npy(&d72.join("error.npy")).unwrap();
    assert_eq!(e.shape, vec![36, 36]);
    assert!(d72.join("error.png").is_file());
    let f = read_npy(&d72.join("fluence.npy")).unwrap().data;
    let c = read_npy(&d36.join("fluence.npy")).unwrap().data;
    let fr = restrict(&f, [72, 72, 1], [36, 36, 1]).unwrap();
    let scale = e.data.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for i in 0..fr.len() {
        let want = (fr[i] - c[i]) / (2f64.powf(p) - 1.0);
        assert!((e.data[i] - want).abs() <= 1e-9 * scale, "cell {i}");
    }
    let max_abs = est["max_abs"].as_f64().unwrap();
    assert!((max_abs - scale).abs() <= 1e-12 * scale);
}

/// `--sampling exact` is the default bit for bit; `--sampling average` changes the answer
/// (the blocks' faces are crossed by control volumes) and is recorded in the report.
#[test]
fn sampling_modes() {
    let (a, b, c) = (dir("sa"), dir("sb"), dir("sc"));
    let run = |d: &PathBuf, extra: &[&str]| {
        let mut args = vec![
            "solve",
            "checkerboard",
            "--order",
            "1",
            "--res",
            "36",
            "--out",
        ];
        args.push(d.to_str().unwrap());
        args.extend_from_slice(extra);
        ok(&pn(&args));
        read_npy(&d.join("fluence.npy")).unwrap().data
    };
    let plain = run(&a, &[]);
    let exact = run(&b, &["--sampling", "exact"]);
    let avg = run(&c, &["--sampling", "average"]);
    assert_eq!(plain, exact);
    assert!(report(&a).get("sampling").is_none());
    assert_eq!(report(&c)["sampling"], "average:8");
    let diff = pn_runtime::convergence::rel_l2_diff(&avg, &exact);
    assert!(diff > 1e-3, "average sampling changed nothing ({diff})");
}

/// The README's P_1 checkerboard study, 71 → 142 → 284 with both samplings (about 2 min on
/// one core): `cargo test --release --test converge_cli -- --ignored --nocapture`.
/// Measured: the difference of 71² to 284² is 0.92 (relative L2) with exact sampling and
/// 0.028 with cell averages; the assertions are the qualitative claims of the README
/// (refinement shrinks the differences; averaging is much closer to the fine answer at 71²).
#[test]
#[ignore]
fn checkerboard_p1_study_71_to_284() {
    let mut d71 = Vec::new();
    for sampling in ["exact", "average"] {
        let d = dir(&format!("study-{sampling}"));
        let o = pn(&[
            "converge",
            "checkerboard",
            "--order",
            "1",
            "--res",
            "71,142,284",
            "--sampling",
            sampling,
            "--out",
            d.to_str().unwrap(),
        ]);
        ok(&o);
        println!("{sampling}:\n{}", String::from_utf8_lossy(&o.stdout));
        let csv = std::fs::read_to_string(d.join("convergence.csv")).unwrap();
        let rows: Vec<Vec<f64>> = csv
            .lines()
            .skip(1)
            .map(|l| {
                l.split(',')
                    .map(|v| v.parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect();
        assert!(
            rows[2][3] < rows[1][3],
            "{sampling}: differences must shrink"
        );
        d71.push(rows[0][4]);
    }
    assert!(d71[1] < 0.25 * d71[0], "average sampling: {d71:?}");
}

/// `pn converge checkerboard --order 1 --res <res> --sampling <sampling>` with parity-cg;
/// returns the output folder and the parsed `convergence.json`.
fn converge_p1_checkerboard(res: &str, sampling: &str, tag: &str) -> (PathBuf, serde_json::Value) {
    let d = dir(&format!("{tag}-{sampling}"));
    let o = pn(&[
        "converge",
        "checkerboard",
        "--order",
        "1",
        "--res",
        res,
        "--solver",
        "parity-cg",
        "--sampling",
        sampling,
        "--out",
        d.to_str().unwrap(),
    ]);
    ok(&o);
    println!("{sampling}:\n{}", String::from_utf8_lossy(&o.stdout));
    let json = serde_json::from_str(&std::fs::read_to_string(d.join("convergence.json")).unwrap())
        .unwrap();
    (d, json)
}

/// The estimate at 71² brackets the difference to the finest grid: P_1
/// checkerboard 71/142/284 with parity-cg, for both samplings. The estimate of level 71 is
/// built from 71 and 142 only (`estimate_next`, with the order of 71/142/284); it brackets
/// when `diff_finest ≤ estimate ≤ 2·diff_finest` (the estimate is not optimistic, and at most
/// 2× pessimistic). Measured (this test's run, finest 284): exact 0.920 vs 1.066 (p = 3.79),
/// average 0.0281 vs 0.0520 (p = 1.39). With 568 as the finest level (the ignored
/// `checkerboard_p1_bracketing_to_568`) the 71² estimates bracket as well (exact 0.634 vs
/// 0.911, average 0.0280 vs 0.0515), but the exact-sampling estimate at 142² does not
/// (0.082 against a difference of 0.213): that sequence is not monotone (the block geometry
/// the grid sees changes with n mod 7, README "How accurate is my answer?"), so its 142/284
/// pair says nothing about 568. About 7 s in release.
#[test]
fn checkerboard_p1_estimate_brackets_at_71() {
    for sampling in ["exact", "average"] {
        let (d, json) = converge_p1_checkerboard("71,142,284", sampling, "bracket");
        let rows = json["table"]["rows"].as_array().unwrap();
        let est = rows[0]["estimate_next"].as_f64().unwrap();
        let diff = rows[0]["diff_finest"].as_f64().unwrap();
        assert!(
            diff <= est && est <= 2.0 * diff,
            "{sampling}: estimate {est} does not bracket the difference {diff} to 284²"
        );
        assert_eq!(rows[0]["bracketed"], serde_json::json!(true), "{sampling}");
        // Undefined next to the finest level and for the finest level itself.
        assert!(rows[1]["bracketed"].is_null() && rows[2]["estimate_next"].is_null());
        let csv = std::fs::read_to_string(d.join("convergence.csv")).unwrap();
        assert!(csv
            .lines()
            .next()
            .unwrap()
            .ends_with("estimate_next,estimate_next_order,bracketed"));
        let _ = std::fs::remove_dir_all(&d);
    }
}

/// The same to 568² (slow: ~30 s and ~45 s wall on a loaded 2-core machine). What holds:
/// both samplings bracket at 71²; at 142² the average-sampling estimate is conservative
/// (≥ the difference to 568², measured 0.0162 vs 0.0073, 2.2×: just outside the factor 2)
/// while the exact-sampling one is optimistic (0.082 vs 0.213) because that sequence is not
/// monotone.
#[test]
#[ignore]
fn checkerboard_p1_bracketing_to_568() {
    for sampling in ["exact", "average"] {
        let (d, json) = converge_p1_checkerboard("71,142,284,568", sampling, "bracket568");
        let rows = json["table"]["rows"].as_array().unwrap();
        assert_eq!(
            rows[0]["bracketed"],
            serde_json::json!(true),
            "{sampling} at 71"
        );
        let est = rows[1]["estimate_next"].as_f64().unwrap();
        let diff = rows[1]["diff_finest"].as_f64().unwrap();
        if sampling == "average" {
            assert!(est >= diff, "average at 142: {est} vs {diff}");
        } else {
            assert!(
                est < diff,
                "exact at 142 was measured optimistic: {est} vs {diff}"
            );
        }
        let _ = std::fs::remove_dir_all(&d);
    }
}
