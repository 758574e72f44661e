//! The renderers' progress bar (to be replaced by a callback the command line draws).

/// An indicatif progress bar that is hidden unless stderr is a terminal.
pub(crate) fn progress_bar(len: usize, enabled: bool) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !enabled || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(len as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {pos} it  {msg}  ({per_sec})",
    ) {
        pb.set_style(style);
    }
    pb
}
