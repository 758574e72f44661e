//! `pn export-mitsuba` and `pn compare` from the command line (no Mitsuba needed).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_formats::write_exr_gray;
use std::path::{Path, PathBuf};

mod support;
use support::pn;

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn export_writes_vol_and_script() {
    let d = dir("cli_export_mitsuba");
    let out = d.join("mi");
    let o = pn(&[
        "export-mitsuba",
        "lowalbedo",
        "--out",
        out.to_str().unwrap(),
        "--spp",
        "8",
        "--max-depth",
        "2",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let script = std::fs::read_to_string(out.join("render_mitsuba.py")).unwrap();
    assert!(script.contains("SPP = 8\n") && script.contains("MAX_DEPTH = 2\n"));
    // 32³ float32 voxels after the 48-byte header.
    let vol = std::fs::metadata(out.join("density.vol")).unwrap().len();
    assert_eq!(vol, 48 + 4 * 32 * 32 * 32);

    let o = pn(&[
        "export-mitsuba",
        "lowalbedo",
        "--out",
        out.to_str().unwrap(),
        "--max-depth",
        "0",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("max_depth"));
    let o = pn(&[
        "export-mitsuba",
        "no-such-scene",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("built-in"));
}

#[test]
fn compare_prints_metrics_and_refuses_size_mismatch() {
    let d = dir("cli_compare");
    let (a, b, c) = (d.join("a.exr"), d.join("b.exr"), d.join("c.exr"));
    write_exr_gray(&a, 4, 2, &[1.1, 0.9, 1.1, 0.9, 1.1, 0.9, 1.1, 0.9]).unwrap();
    write_exr_gray(&b, 4, 2, &[1.0; 8]).unwrap();
    write_exr_gray(&c, 2, 4, &[1.0; 8]).unwrap();
    let out = d.join("cmp");
    let o = pn(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let json: serde_json::Value =
        serde_json::from_str(&stdout[..stdout.rfind('}').unwrap() + 1]).unwrap();
    // f32 pixels: 1.1f32 − 1 = 0.100000024.
    assert!((json["rmse"].as_f64().unwrap() - 0.1).abs() < 1e-6);
    assert!(out.join("difference.png").is_file() && out.join("metrics.json").is_file());

    let o = pn(&["compare", a.to_str().unwrap(), c.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("differ in size"));
    let o = pn(&[
        "compare",
        a.to_str().unwrap(),
        d.join("missing.exr").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
}
