//! Shared by the integration tests: running the `pn` binary, finding Mitsuba's Python and
//! scratch folders.
#![allow(dead_code)]

use pn_runtime::render::mitsuba;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The Mitsuba interpreter, or `None` (test skipped) when there is none and
/// PN_REQUIRE_MITSUBA is not 1.
pub fn mitsuba_python() -> Option<PathBuf> {
    let required = std::env::var("PN_REQUIRE_MITSUBA").is_ok_and(|v| v == "1");
    let found = mitsuba::find_python(None).and_then(|p| {
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

/// Asserts that a `pn` run succeeded, showing its output otherwise.
pub fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}
