//! JSON reports written atomically: the value is serialised first, then written to a
//! temporary file in the target's directory and renamed over the target, so a report appears
//! only when complete and a report that cannot be written leaves no half-written file.

use anyhow::Context;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Writes `value` as pretty-printed JSON (with a final newline) to `path`, atomically: a
/// temporary file `.<name>.tmp-<pid>` next to `path` is written and renamed onto `path`. On
/// any error the temporary file is removed and `path` is left as it was.
pub fn write_atomic<T: Serialize + ?Sized>(path: &Path, value: &T) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)
        .with_context(|| format!("serialising {}", path.display()))?
        + "\n";
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .with_context(|| format!("{} has no file name", path.display()))?;
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let written = std::fs::write(&tmp, text)
        .with_context(|| format!("writing {}", path.display()))
        .and_then(|()| {
            std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))
        });
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("pn-formats-json-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[derive(Serialize)]
    struct Example {
        b: u32,
        a: Option<f64>,
    }

    #[test]
    fn writes_pretty_json_in_field_order_and_leaves_no_temporary() {
        let dir = scratch("ok");
        let path = dir.join("report.json");
        write_atomic(&path, &Example { b: 1, a: None }).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "{\n  \"b\": 1,\n  \"a\": null\n}\n"
        );
        // Overwrites in place.
        write_atomic(&path, &Example { b: 2, a: Some(0.5) }).unwrap();
        assert!(std::fs::read_to_string(&path).unwrap().contains("\"b\": 2"));
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(names.len(), 1, "only report.json: {names:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_report_that_cannot_be_written_leaves_nothing() {
        let dir = scratch("fail");
        // The target is a directory: the rename fails after the temporary was written.
        let path = dir.join("report.json");
        std::fs::create_dir(&path).unwrap();
        std::fs::write(path.join("keep"), "x").unwrap();
        assert!(write_atomic(&path, &Example { b: 1, a: None }).is_err());
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["report.json"]);
        assert!(path.join("keep").exists());
        // A missing directory: nothing is created.
        let missing = dir.join("missing").join("report.json");
        assert!(write_atomic(&missing, &Example { b: 1, a: None }).is_err());
        assert!(!dir.join("missing").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
