//! What a command shows on the terminal while and after a library works: the progress bar
//! of a solve, drawn from the solver's iteration observer, and the notes a library returns
//! (the libraries never draw or print).

use pn_runtime::solver::IterationObserver;
use std::io::IsTerminal;

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
    let bar = indicatif::ProgressBar::new_spinner();
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {pos} it  {msg}  ({per_sec})",
    ) {
        bar.set_style(style);
    }
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
