//! Shared by the integration tests: running the `pn` binary, finding Mitsuba's Python,
//! scratch folders, the StaRMAP references of `tests/data` and the relative difference the
//! validation tests bound.
#![allow(dead_code)]

use pn_drivers::mitsuba;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The Mitsuba interpreter, or `None` (test skipped) when there is none and
/// PN_REQUIRE_MITSUBA is not 1.
pub fn mitsuba_python() -> Option<PathBuf> {
    let required = std::env::var("PN_REQUIRE_MITSUBA").is_ok_and(|v| v == "1");
    let chosen = std::env::var_os(pn_render::mitsuba::PYTHON_ENV)
        .filter(|p| !p.is_empty())
        .map(PathBuf::from);
    let found = mitsuba::find_python(chosen.as_deref()).and_then(|p| {
        let version = mitsuba::check_python(&p)?;
        eprintln!("using Mitsuba {version} from {}", p.display());
        Ok(p)
    });
    match found {
        Ok(p) => Some(p),
        Err(e) if required => panic!("PN_REQUIRE_MITSUBA=1 but Mitsuba is unavailable: {e:#}"),
        Err(e) => {
            eprintln!("SKIPPED (no Mitsuba; set PN_REQUIRE_MITSUBA=1 to fail instead): {e:#}");
            None
        }
    }
}

pub fn work_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Runs the `pn` binary with `args`.
pub fn pn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pn"))
        .args(args)
        .output()
        .unwrap()
}

/// A StaRMAP reference from `tests/data/checkerboard` as x-slowest values, read by
/// `pn_runtime::reference::starmap::read_csv`; a missing or malformed file fails the test.
pub fn starmap_reference(file: &str) -> Vec<f64> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/checkerboard")
        .join(file);
    pn_runtime::reference::starmap::read_csv(&path).unwrap_or_else(|e| panic!("{e:#}"))
}

/// max|a − b| / max|b| over all entries; the two must have the same length.
pub fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let m = b.iter().fold(0.0f64, |x, y| x.max(y.abs()));
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / m
}

/// Asserts that a `pn` run succeeded, showing its output otherwise.
pub fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}
