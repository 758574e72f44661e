//! Reading an input file in bounded steps: a regular file only (never a stream such as
//! `/dev/zero`, a device or a folder), its header first, then exactly the bytes the header
//! declares, after checking them against the file's length.

use anyhow::{ensure, Context};
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Opens `path` as a regular file; returns it with its length in bytes.
pub(crate) fn open_regular(path: &Path) -> anyhow::Result<(File, u64)> {
    let file = File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let meta = file
        .metadata()
        .with_context(|| format!("cannot read {}", path.display()))?;
    ensure!(
        meta.is_file(),
        "cannot read {}: not a regular file (a folder, device or stream)",
        path.display()
    );
    Ok((file, meta.len()))
}

/// Reads the next `n` bytes of `file`, or up to its end when it is shorter.
pub(crate) fn read_up_to(file: &mut File, n: u64) -> anyhow::Result<Vec<u8>> {
    let mut out = Vec::new();
    file.take(n).read_to_end(&mut out).context("read error")?;
    Ok(out)
}

/// Appends the rest of a file of `len` bytes to `head` (what was read of it so far); the
/// caller has checked `len` against what the header declares.
pub(crate) fn read_rest(file: &mut File, mut head: Vec<u8>, len: u64) -> anyhow::Result<Vec<u8>> {
    let rest = len.saturating_sub(head.len() as u64);
    let want = usize::try_from(len).context("the file is too large for this machine")?;
    head.try_reserve_exact(want.saturating_sub(head.len()))
        .with_context(|| format!("cannot hold {len} bytes in memory"))?;
    file.take(rest)
        .read_to_end(&mut head)
        .context("read error")?;
    ensure!(
        head.len() as u64 == len,
        "the file changed while it was read ({} of {len} bytes)",
        head.len()
    );
    Ok(head)
}

/// The largest text input read (a scene, a PDE, a study): far above any real one, far
/// below what would exhaust memory.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

/// Reads a text input file (UTF-8): a regular file of at most [`MAX_TEXT_BYTES`], so that a
/// stream (`/dev/zero`) or a huge file is refused at once instead of read until memory ends.
pub fn read_text(path: &Path) -> anyhow::Result<String> {
    let (mut file, len) = open_regular(path)?;
    ensure!(
        len <= MAX_TEXT_BYTES,
        "{} is {len} bytes, more than the {} MiB a text input may have",
        path.display(),
        MAX_TEXT_BYTES >> 20
    );
    let bytes = read_rest(&mut file, Vec::new(), len)?;
    String::from_utf8(bytes).with_context(|| format!("{} is not UTF-8 text", path.display()))
}
