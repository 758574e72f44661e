//! What a command shows on the terminal while and after a library works: the progress bars
//! of a solve (from the solver's iteration observer) and of a render (from the renderer's
//! row callback), and the notes a library returns (the libraries never draw or print).

use pn_render::ProgressCallback;
use pn_runtime::solver::IterationObserver;
use std::io::IsTerminal;
use std::sync::Mutex;

/// `bar` with the look of every bar of the commands: spinner, elapsed time, count, message,
/// rate.
fn styled(bar: indicatif::ProgressBar) -> indicatif::ProgressBar {
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {pos} it  {msg}  ({per_sec})",
    ) {
        bar.set_style(style);
    }
    bar
}

/// An observer that draws a spinner with the iteration count and the relative residual on
/// stderr, cleared when the solve ends; `None` when `enabled` is false or stderr is not a
/// terminal. With `inner`, that observer is told of every iteration as well.
pub fn terminal_observer(
    enabled: bool,
    inner: Option<IterationObserver>,
) -> Option<IterationObserver> {
    if !enabled || !std::io::stderr().is_terminal() {
        return inner;
    }
    let bar = styled(indicatif::ProgressBar::new_spinner());
    let done = bar.clone();
    let inner_done = inner.clone();
    Some(IterationObserver::with_finish(
        move |iteration, relative_residual| {
            // As the bar of the solver did: redrawn every 16 iterations.
            if iteration.is_multiple_of(16) {
                bar.set_position(iteration as u64);
                bar.set_message(format!("relative residual {relative_residual:.3e}"));
            }
            if let Some(o) = &inner {
                o.notify(iteration, relative_residual);
            }
        },
        move || {
            done.finish_and_clear();
            if let Some(o) = &inner_done {
                o.finish();
            }
        },
    ))
}

/// Prints what a library returned for the user to read (notes, warnings, per-phase timings
/// when asked for) to stderr, one line each, as the command's own output.
pub fn print_notes(notes: &[String]) {
    for note in notes {
        eprintln!("{note}");
    }
}

/// A progress bar over the image rows ("image rows"), one per image, hidden unless stderr
/// is a terminal.
pub fn row_progress_bar() -> ProgressCallback {
    let bar: Mutex<Option<indicatif::ProgressBar>> = Mutex::new(None);
    ProgressCallback::new(move |done, total| {
        // A poisoned lock only loses the bar.
        let Ok(mut bar) = bar.lock() else {
            return;
        };
        if done == 0 {
            *bar = Some(row_bar(total));
            return;
        }
        if let Some(b) = bar.as_ref() {
            b.set_position(b.position().max(done as u64));
        }
        if done == total {
            if let Some(b) = bar.take() {
                b.finish_and_clear();
            }
        }
    })
}

/// An indicatif bar of `len` rows, hidden unless stderr is a terminal.
fn row_bar(len: usize) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = styled(indicatif::ProgressBar::new(len as u64));
    bar.set_message("image rows");
    bar
}
