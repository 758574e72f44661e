//! Progress of a render as values: the library calls a [`ProgressCallback`], the command
//! draws a bar (or not); nothing here touches a terminal.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// Called with `(done, total)` while an image is rendered: `(0, total)` before its first row,
/// then once per finished row with the count of rows done so far (rows finish in parallel,
/// so the counts may arrive out of order; `total` arrives exactly once per image after
/// `0`). The command draws a progress bar from it; the library draws nothing.
#[derive(Clone)]
pub struct ProgressCallback(pub Arc<dyn Fn(usize, usize) + Send + Sync>);

impl ProgressCallback {
    /// Wraps `f`.
    pub fn new(f: impl Fn(usize, usize) + Send + Sync + 'static) -> Self {
        Self(Arc::new(f))
    }

    /// Reports `done` of `total` rows.
    pub fn report(&self, done: usize, total: usize) {
        (self.0)(done, total)
    }
}

impl std::fmt::Debug for ProgressCallback {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ProgressCallback(..)")
    }
}

impl PartialEq for ProgressCallback {
    /// The same function object.
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Counts the finished rows of one image for a [`ProgressCallback`] (rows finish on any
/// thread).
pub(crate) struct RowCounter<'a> {
    callback: Option<&'a ProgressCallback>,
    done: AtomicUsize,
    total: usize,
}

impl<'a> RowCounter<'a> {
    /// Reports `(0, total)` and counts from there.
    pub(crate) fn start(callback: Option<&'a ProgressCallback>, total: usize) -> Self {
        if let Some(c) = callback {
            c.report(0, total);
        }
        Self {
            callback,
            done: AtomicUsize::new(0),
            total,
        }
    }

    /// One more row finished.
    pub(crate) fn row_done(&self) {
        if let Some(c) = self.callback {
            let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
            c.report(done, self.total);
        }
    }
}
