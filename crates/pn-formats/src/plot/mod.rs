//! Plotters scaffolding shared by the PNG plots (the convergence study, the point-source
//! profiles): the white canvas, the chart frame, the legend box and the error text; and
//! those plots: [`write_convergence_png`], and the point-source profiles as CSV
//! ([`write_profile_csv`]) and PNG ([`write_profile_png`], [`write_profile_png_titled`]), and
//! the false-colour difference of two images ([`write_difference_png`]).

mod convergence;
mod difference;
mod profile;

pub use convergence::write_convergence_png;
pub use difference::write_difference_png;
pub use profile::{
    write_profile_csv, write_profile_png, write_profile_png_titled, PROFILE_CSV_HEADER,
};

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

/// The error a plot reports when plotters fails: `drawing <path>: <error>`.
pub fn draw_error(path: &Path, e: &dyn std::fmt::Display) -> anyhow::Error {
    anyhow!("drawing {}: {e}", path.display())
}

/// A bitmap canvas of `size` pixels, filled white, to be written to `path`.
pub fn white_canvas(
    path: &Path,
    size: (u32, u32),
) -> Result<DrawingArea<BitMapBackend<'_>, Shift>> {
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_error(path, &e))?;
    Ok(root)
}

/// A chart builder on `root` with the plots' frame: `title` in sans-serif at `caption_size`,
/// a 20 px margin and label areas of 60 px (x axis) and 90 px (y axis).
pub fn framed_chart<'a, 'b>(
    root: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    title: &str,
    caption_size: u32,
) -> ChartBuilder<'a, 'b, BitMapBackend<'b>> {
    let mut builder = ChartBuilder::on(root);
    builder
        .caption(title, ("sans-serif", caption_size))
        .margin(20)
        .x_label_area_size(60)
        .y_label_area_size(90);
    builder
}

/// Draws the legend (sans-serif at `font_size`, on translucent white with a black border) at
/// `position`, then writes the canvas to its file.
pub fn finish_chart<'a, 'b: 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, BitMapBackend<'b>, CT>,
    root: &DrawingArea<BitMapBackend<'b>, Shift>,
    path: &Path,
    font_size: u32,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .label_font(("sans-serif", font_size))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()
        .map_err(|e| draw_error(path, &e))?;
    root.present().map_err(|e| draw_error(path, &e))?;
    Ok(())
}

/// Registers the fonts plotters draws text with (the workspace builds plotters with its
/// `ab_glyph` backend, which has no system fonts): "sans-serif" and "serif" are Ubuntu Light,
/// "monospace" is Hack, both embedded by the `epaint_default_fonts` crate. Idempotent; call it
/// before drawing any text with plotters.
pub fn register_plot_fonts() -> Result<()> {
    static REGISTERED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            let fonts: [(&str, &'static [u8]); 3] = [
                ("sans-serif", epaint_default_fonts::UBUNTU_LIGHT),
                ("serif", epaint_default_fonts::UBUNTU_LIGHT),
                ("monospace", epaint_default_fonts::HACK_REGULAR),
            ];
            for (name, bytes) in fonts {
                for style in [
                    FontStyle::Normal,
                    FontStyle::Bold,
                    FontStyle::Italic,
                    FontStyle::Oblique,
                ] {
                    plotters::style::register_font(name, style, bytes)
                        .map_err(|_| format!("embedded font for {name:?} is not a valid font"))?;
                }
            }
            Ok(())
        })
        .clone()
        .map_err(|e| anyhow!(e))
}
