//! Plain files whose bytes a library computed: folders created, files written as given (a
//! Mitsuba export's `.vol` volumes and Python script, whose contents `pn-render` returns).

use anyhow::Context;
use std::path::Path;

/// Creates `dir` and its missing parents (`cannot create <dir>` on error).
pub fn create_dir_all(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))
}

/// Writes `contents` to `path`, replacing it (`cannot write <path>` on error).
pub fn write(path: &Path, contents: impl AsRef<[u8]>) -> anyhow::Result<()> {
    std::fs::write(path, contents).with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_into_a_created_folder_and_names_the_path_on_error() {
        let dir = std::env::temp_dir().join(format!("pn-files-{}", std::process::id()));
        let sub = dir.join("a/b");
        create_dir_all(&sub).unwrap();
        write(&sub.join("x.txt"), "hello\n").unwrap();
        assert_eq!(std::fs::read(sub.join("x.txt")).unwrap(), b"hello\n");
        let e = write(&dir.join("missing/x.txt"), [1u8, 2]).unwrap_err();
        assert!(format!("{e:#}").contains("cannot write"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
