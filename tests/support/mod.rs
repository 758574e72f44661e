//! Shared by the Mitsuba comparison tests: finding Mitsuba's Python and scratch folders.
#![allow(dead_code)]

use pn_runtime::render::mitsuba;
use std::path::{Path, PathBuf};

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
