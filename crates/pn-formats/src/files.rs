//! Plain files whose bytes a library computed: folders created, files written as given (a
//! Mitsuba export's `.vol` volumes and Python script, whose contents `pn-render` returns).

use anyhow::Context;
use std::path::{Path, PathBuf};

/// Creates `dir` and its missing parents (`cannot create <dir>` on error).
pub fn create_dir_all(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))
}

/// Checks, without creating anything, that `dir` can become an output folder: it is a folder
/// already, or the nearest part of its path that exists is a folder (so that
/// [`create_dir_all`] can make the rest). Commands call it before any expensive work, so that
/// a typing error in `--out` costs nothing (issue 53).
pub fn check_output_dir(dir: &Path) -> anyhow::Result<()> {
    let Some(existing) = dir
        .ancestors()
        .find(|a| a.as_os_str().is_empty() || a.symlink_metadata().is_ok())
    else {
        return Ok(());
    };
    if existing.as_os_str().is_empty() || existing.is_dir() {
        return Ok(());
    }
    if existing == dir {
        anyhow::bail!(
            "cannot create the output folder {}: a file of that name is in the way",
            dir.display()
        );
    }
    anyhow::bail!(
        "cannot create the output folder {}: {} is not a folder",
        dir.display(),
        existing.display()
    )
}

/// A folder's files, written into a temporary folder beside it and moved into it together
/// by [`StagedDir::commit`]. A failure before that (the value dropped without a commit)
/// leaves nothing behind: neither the temporary folder nor the parents it needed (issue 53).
pub struct StagedDir {
    dir: PathBuf,
    temp: PathBuf,
    /// Parents of `dir` this value created, deepest first.
    made: Vec<PathBuf>,
    committed: bool,
}

impl StagedDir {
    /// Creates the temporary folder `.<name>.partial-<pid>` beside `dir`.
    pub fn new(dir: &Path) -> anyhow::Result<Self> {
        let parent = match dir.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let made: Vec<PathBuf> = parent
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .map(Path::to_path_buf)
            .collect();
        let leaf = dir.file_name().and_then(|n| n.to_str()).unwrap_or("out");
        let mut staged = Self {
            dir: dir.to_path_buf(),
            temp: parent.join(format!(".{leaf}.partial-{}", std::process::id())),
            made,
            committed: false,
        };
        create_dir_all(&parent)?;
        let _ = std::fs::remove_dir_all(&staged.temp);
        if let Err(e) = std::fs::create_dir(&staged.temp) {
            staged.temp = PathBuf::new();
            return Err(e).with_context(|| format!("cannot create {}", dir.display()));
        }
        Ok(staged)
    }

    /// Where the files are written.
    pub fn path(&self) -> &Path {
        &self.temp
    }

    /// Moves every file written into the folder (created if missing; files of the same
    /// names replaced).
    pub fn commit(mut self) -> anyhow::Result<()> {
        create_dir_all(&self.dir)?;
        let entries = std::fs::read_dir(&self.temp)
            .with_context(|| format!("cannot read {}", self.temp.display()))?;
        for entry in entries {
            let entry = entry.with_context(|| format!("cannot read {}", self.temp.display()))?;
            let to = self.dir.join(entry.file_name());
            std::fs::rename(entry.path(), &to)
                .with_context(|| format!("cannot write {}", to.display()))?;
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.temp.as_os_str().is_empty() {
            let _ = std::fs::remove_dir_all(&self.temp);
        }
        if !self.committed {
            // Only folders this value made, and only while empty.
            for d in &self.made {
                let _ = std::fs::remove_dir(d);
            }
        }
    }
}

/// Writes `contents` to `path`, replacing it (`cannot write <path>` on error).
pub fn write(path: &Path, contents: impl AsRef<[u8]>) -> anyhow::Result<()> {
    std::fs::write(path, contents).with_context(|| format!("cannot write {}", path.display()))
}

/// Writes the files `(name, contents)` into `dir` all or none: each first to a temporary
/// name beside its place, then renamed once every one is written. On an error nothing is
/// left behind: the temporary files go, and so does `dir` (with the parents this call
/// created) where it did not exist before.
pub fn write_all_or_none(dir: &Path, files: &[(&str, &[u8])]) -> anyhow::Result<()> {
    let missing: Vec<&Path> = dir
        .ancestors()
        .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
        .collect();
    let mut temps: Vec<std::path::PathBuf> = Vec::new();
    let result = (|| -> anyhow::Result<()> {
        create_dir_all(dir)?;
        for (name, _) in files {
            let path = dir.join(name);
            anyhow::ensure!(
                !path.is_dir(),
                "cannot write {}: a folder of that name is in the way",
                path.display()
            );
        }
        for (name, bytes) in files {
            let temp = dir.join(format!(".{name}.partial-{}", std::process::id()));
            temps.push(temp.clone());
            std::fs::write(&temp, bytes)
                .with_context(|| format!("cannot write {}", dir.join(name).display()))?;
        }
        for ((name, _), temp) in files.iter().zip(&temps) {
            let path = dir.join(name);
            std::fs::rename(temp, &path)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
        Ok(())
    })();
    if result.is_err() {
        for t in &temps {
            let _ = std::fs::remove_file(t);
        }
        // Only folders this call made, and only while empty.
        for d in &missing {
            let _ = std::fs::remove_dir(d);
        }
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_folders_are_checked_without_creating_anything() {
        let dir = std::env::temp_dir().join(format!("pn-outcheck-{}", std::process::id()));
        create_dir_all(&dir).unwrap();
        // A folder, a missing folder under a folder, a relative path: fine, nothing made.
        check_output_dir(&dir).unwrap();
        check_output_dir(&dir.join("new/deeper")).unwrap();
        assert!(!dir.join("new").exists());
        check_output_dir(Path::new("some-relative-folder-that-is-not-there")).unwrap();
        // A file in the way, as the folder itself or as a parent.
        let file = dir.join("afile");
        write(&file, "x").unwrap();
        let e = format!("{:#}", check_output_dir(&file).unwrap_err());
        assert!(e.contains("a file of that name is in the way"), "{e}");
        let e = format!("{:#}", check_output_dir(&file.join("x/y")).unwrap_err());
        assert!(e.contains("afile is not a folder"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_staged_folder_appears_whole_or_not_at_all() {
        let root = std::env::temp_dir().join(format!("pn-staged-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = root.join("a/b/out");
        // Dropped without a commit: nothing is left, not even the parents it made.
        {
            let s = StagedDir::new(&dir).unwrap();
            write(&s.path().join("x.txt"), "1").unwrap();
        }
        assert!(!root.exists());
        // Committed: the files and only them, into a folder that may hold others.
        let s = StagedDir::new(&dir).unwrap();
        write(&s.path().join("x.txt"), "1").unwrap();
        write(&s.path().join("y.txt"), "2").unwrap();
        s.commit().unwrap();
        let s = StagedDir::new(&dir).unwrap();
        write(&s.path().join("x.txt"), "3").unwrap();
        s.commit().unwrap();
        let mut names: Vec<String> = std::fs::read_dir(dir.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["out"]);
        assert_eq!(std::fs::read_to_string(dir.join("x.txt")).unwrap(), "3");
        assert_eq!(std::fs::read_to_string(dir.join("y.txt")).unwrap(), "2");
        std::fs::remove_dir_all(&root).unwrap();
    }

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

    #[test]
    fn all_or_none_leaves_nothing_on_refusal() {
        let dir = std::env::temp_dir().join(format!("pn-files-aon-{}", std::process::id()));
        let out = dir.join("new/export");
        write_all_or_none(&out, &[("a.bin", b"1"), ("b.txt", b"2")]).unwrap();
        assert_eq!(std::fs::read(out.join("b.txt")).unwrap(), b"2");
        // A folder where the second file goes: the first is not written either.
        let out2 = dir.join("fresh/export");
        std::fs::create_dir_all(out2.join("b.txt")).unwrap();
        let e = write_all_or_none(&out2, &[("a.bin", b"1"), ("b.txt", b"2")]).unwrap_err();
        assert!(format!("{e:#}").contains("b.txt"), "{e:#}");
        let left: Vec<_> = std::fs::read_dir(&out2).unwrap().collect();
        assert_eq!(left.len(), 1, "{left:?}");
        // A parent that is a file: no folder made.
        std::fs::write(dir.join("file"), b"x").unwrap();
        assert!(write_all_or_none(&dir.join("file/sub"), &[("a.bin", b"1")]).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
