//! Bad input to `pn solve`: one clear error line, non-zero exit, nothing written.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use std::path::{Path, PathBuf};
use std::process::Command;

struct Case {
    dir: PathBuf,
}

impl Case {
    fn new(name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("pn-solve-errors-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Case { dir }
    }

    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// Runs `pn solve <args> --out <dir>/out`, expects failure, returns the stderr line.
    fn fails(&self, args: &[&str]) -> String {
        let out_dir = self.dir.join("out");
        let out = Command::new(env!("CARGO_BIN_EXE_pn"))
            .arg("solve")
            .args(args)
            .arg("--out")
            .arg(&out_dir)
            .output()
            .expect("run pn");
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(
            !out.status.success(),
            "pn solve {args:?} should fail; stderr: {stderr}"
        );
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "expected one error line, got: {stderr}");
        assert!(lines[0].starts_with("error"), "{stderr}");
        eprintln!("{args:?}: {}", lines[0]);
        assert!(
            !out_dir.exists(),
            "output directory was created for {args:?}"
        );
        // No temporary leftovers next to it either.
        let leftovers: Vec<_> = std::fs::read_dir(&self.dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
            .collect();
        assert!(leftovers.is_empty(), "temporary files left behind");
        lines[0].to_string()
    }

    fn path(&self, p: &Path) -> String {
        p.to_string_lossy().into_owned()
    }
}

impl Drop for Case {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A .vol header (docs/design.md §6) for a grid of the given size and encoding, plus `values`.
fn vol(encoding: i32, dims: [i32; 3], values: &[f32]) -> Vec<u8> {
    let mut b = b"VOL\x03".to_vec();
    for v in [encoding, dims[0], dims[1], dims[2], 1] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for v in [0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for v in values {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b
}

const SCENE_HEAD: &str =
    "dim = 3\nresolution = [2, 2, 2]\nalbedo = 0.5\n[[source]]\nl = 0\nm = 0\nvalue = 1.0\n";

#[test]
fn unknown_scene() {
    let c = Case::new("unknown");
    let e = c.fails(&["no-such-scene"]);
    assert!(e.contains("unknown scene"), "{e}");
}

#[test]
fn missing_scene_file() {
    let c = Case::new("missing");
    let e = c.fails(&["does/not/exist.toml"]);
    assert!(e.contains("cannot read scene file"), "{e}");
}

#[test]
fn malformed_toml_reports_line_and_column() {
    let c = Case::new("malformed");
    let p = c.file("bad.toml", b"dim = 3\nsigma_t = [1, \nalbedo = 0.5\n");
    let e = c.fails(&[&c.path(&p)]);
    assert!(e.contains("bad.toml:"), "{e}");
    let p = c.file(
        "unknown.toml",
        format!("sigma_t = 1.0\n{SCENE_HEAD}colour = 3\n").as_bytes(),
    );
    let e = c.fails(&[&c.path(&p)]);
    assert!(
        e.contains("unknown.toml:9:1") && e.contains("colour"),
        "{e}"
    );
}

#[test]
fn vol_with_wrong_size_or_encoding() {
    let c = Case::new("vol");
    c.file("short.vol", &vol(1, [2, 2, 2], &[1.0; 7]));
    c.file("enc.vol", &vol(2, [2, 2, 2], &[1.0; 8]));
    for (name, want) in [("short", "bytes of data"), ("enc", "encoding")] {
        let scene = format!("sigma_t = {{ file = \"{name}.vol\" }}\n{SCENE_HEAD}");
        let p = c.file(&format!("{name}.toml"), scene.as_bytes());
        let e = c.fails(&[&c.path(&p)]);
        assert!(
            e.contains(want) && e.contains(&format!("{name}.vol")),
            "{e}"
        );
    }
}

#[test]
fn nan_and_negative_coefficients() {
    let c = Case::new("coef");
    let p = c.file(
        "nan.toml",
        format!("sigma_t = nan\n{SCENE_HEAD}").as_bytes(),
    );
    let e = c.fails(&[&c.path(&p)]);
    assert!(e.contains("sigma_t") && e.contains("NaN"), "{e}");
    let p = c.file("neg.toml", b"dim = 2\nresolution = [2, 2]\nsigma_t = 1.0\nsigma_s = -0.5\n[[source]]\nl = 0\nm = 0\nvalue = 1.0\n");
    let e = c.fails(&[&c.path(&p)]);
    assert!(e.contains("sigma_s") && e.contains("-0.5"), "{e}");
    c.file(
        "negvox.vol",
        &vol(1, [2, 2, 2], &[1.0, 1.0, 1.0, -2.0, 1.0, 1.0, 1.0, 1.0]),
    );
    let p = c.file(
        "negvox.toml",
        format!("sigma_t = {{ file = \"negvox.vol\" }}\n{SCENE_HEAD}").as_bytes(),
    );
    let e = c.fails(&[&c.path(&p)]);
    assert!(e.contains("negative") && e.contains("(1, 1, 0)"), "{e}");
    // The pointsource's flags are checked too.
    let e = c.fails(&["pointsource", "--albedo", "1.5", "--res", "4"]);
    assert!(e.contains("albedo"), "{e}");
}

#[test]
fn vacuum_needs_a_threshold() {
    let c = Case::new("vacuum");
    let p = c.file(
        "vac.toml",
        format!("sigma_t = 0.0\n{SCENE_HEAD}").as_bytes(),
    );
    let e = c.fails(&[&c.path(&p), "--order", "1"]);
    assert!(e.contains("--sigma-t-min"), "{e}");
    // With a threshold it solves, and the report records it.
    let out_dir = c.dir.join("ok");
    let out = Command::new(env!("CARGO_BIN_EXE_pn"))
        .args([
            "solve",
            &c.path(&p),
            "--order",
            "1",
            "--sigma-t-min",
            "0.5",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("report.json")).unwrap())
            .unwrap();
    assert_eq!(rep["sigma_t_min"], 0.5);
}

#[test]
fn zero_resolution() {
    let c = Case::new("res");
    let e = c.fails(&["checkerboard", "--res", "0"]);
    assert!(e.contains("resolution"), "{e}");
    let p = c.file("zero.toml", b"dim = 3\nresolution = [2, 0, 2]\nsigma_t = 1.0\nalbedo = 0.5\n[[source]]\nl = 0\nm = 0\nvalue = 1.0\n");
    let e = c.fails(&[&c.path(&p)]);
    assert!(e.contains("resolution"), "{e}");
}
