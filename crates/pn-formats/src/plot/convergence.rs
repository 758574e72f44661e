//! `convergence.png`: a log–log plot of a study's differences against the cell size.

use crate::plot::{draw_error, finish_chart, framed_chart, white_canvas};
use anyhow::{bail, Result};
use plotters::prelude::*;
use pn_runtime::convergence::StudyTable;
use std::path::Path;

/// Plots the differences to the finest level (fluence and, if present, block averages) and
/// the Richardson estimates against the cell size `h = extent/res` (x axis 0), with a
/// dashed h² reference line through the first fluence point.
pub fn write_convergence_png(
    path: &Path,
    table: &StudyTable,
    extent: f64,
    title: &str,
) -> Result<()> {
    crate::plot::register_plot_fonts()?;
    let h = |r: &pn_runtime::convergence::StudyRow| extent / r.res[0] as f64;
    type Get = fn(&pn_runtime::convergence::StudyRow) -> Option<f64>;
    let series: [(&str, RGBColor, Get); 3] = [
        (
            "fluence: rel. L2 diff. to finest",
            RGBColor(30, 90, 220),
            |r| r.diff_finest,
        ),
        (
            "block averages: rel. L2 diff. to finest",
            RGBColor(0, 140, 60),
            |r| r.diff_finest_blocks,
        ),
        ("Richardson estimate of the error", RED, |r| r.richardson),
    ];
    let pts: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|(_, _, get)| {
            table
                .rows
                .iter()
                .filter_map(|r| {
                    get(r)
                        .filter(|v| v.is_finite() && *v > 0.0)
                        .map(|v| (h(r), v))
                })
                .collect()
        })
        .collect();
    let all: Vec<(f64, f64)> = pts.iter().flatten().copied().collect();
    if all.is_empty() {
        bail!(
            "{}: nothing to plot (no positive differences)",
            path.display()
        );
    }
    let fold = |f: fn(f64, f64) -> f64, init: f64, sel: fn(&(f64, f64)) -> f64| {
        all.iter().map(sel).fold(init, f)
    };
    let (x0, x1) = (
        fold(f64::min, f64::INFINITY, |p| p.0),
        fold(f64::max, 0.0, |p| p.0),
    );
    let (y0, y1) = (
        fold(f64::min, f64::INFINITY, |p| p.1),
        fold(f64::max, 0.0, |p| p.1),
    );
    let (x0, x1) = (x0 / 1.5, x1 * 1.5);
    let (y0, y1) = (y0 / 3.0, y1 * 3.0);
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let root = white_canvas(path, (1000, 700))?;
    let mut chart = framed_chart(&root, title, 26)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("cell size h")
        .y_desc("relative L2 difference")
        .axis_desc_style(("sans-serif", 22))
        .label_style(("sans-serif", 18))
        .x_labels(6)
        .x_label_formatter(&|v| format!("{v:.3}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| err(&e))?;
    for ((name, colour, _), p) in series.iter().zip(&pts) {
        if p.is_empty() {
            continue;
        }
        let style = ShapeStyle::from(colour).stroke_width(2);
        let c = *colour;
        chart
            .draw_series(LineSeries::new(p.clone(), style))
            .map_err(|e| err(&e))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2)));
        chart
            .draw_series(p.iter().map(|q| Circle::new(*q, 4, c.filled())))
            .map_err(|e| err(&e))?;
    }
    if let Some(&(hx, v)) = pts[0].first() {
        let line: Vec<(f64, f64)> = [x0, x1]
            .iter()
            .map(|&x| (x, v * (x / hx).powi(2)))
            .collect();
        chart
            .draw_series(DashedLineSeries::new(line, 8, 6, BLACK.stroke_width(1)))
            .map_err(|e| err(&e))?
            .label("slope 2 (h²)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], BLACK));
    }
    finish_chart(&mut chart, &root, path, 18, SeriesLabelPosition::LowerRight)
}
