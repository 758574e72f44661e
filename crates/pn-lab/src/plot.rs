//! The plot fonts of the lab, registered from one place: every experiment that draws text
//! with plotters calls [`fonts`] first.

/// Registers the fonts plotters draws text with ("sans-serif", "serif", "monospace"); the
/// registration itself runs once per process, later calls return its result.
pub(crate) fn fonts() -> anyhow::Result<()> {
    pn_formats::plot::register_plot_fonts()
}
