//! The point-source profile outputs (docs/pointsource.md): `profile.csv` and `profile.png`.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use anyhow::{bail, Context, Result};
use plotters::prelude::*;

use super::{draw_error, finish_chart, framed_chart, register_plot_fonts, white_canvas};
use pn_runtime::reference::ProfileRow;

/// The CSV header [`write_profile_csv`] writes.
pub const PROFILE_CSV_HEADER: &str = "tau,solved,pn_exact,cda,grosjean";

/// Writes `rows` as CSV with the header `tau,solved,pn_exact,cda,grosjean`, one row per
/// sample, values in Rust's shortest round-trip form.
pub fn write_profile_csv(path: impl AsRef<Path>, rows: &[ProfileRow]) -> Result<()> {
    let path = path.as_ref();
    let file = File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut w = BufWriter::new(file);
    writeln!(w, "{PROFILE_CSV_HEADER}")?;
    for r in rows {
        writeln!(
            w,
            "{},{},{},{},{}",
            r.tau, r.solved, r.pn_exact, r.cda, r.grosjean
        )?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Writes a log-scale line plot of the profile (normalised fluence against τ; the discrete
/// solution as markers, the reference solutions as lines) to a PNG file.
pub fn write_profile_png(path: impl AsRef<Path>, rows: &[ProfileRow]) -> Result<()> {
    write_profile_png_titled(path, rows, "Point source: normalised fluence along +x")
}

/// [`write_profile_png`] with a caption of the caller's choice (e.g. naming N and α).
pub fn write_profile_png_titled(
    path: impl AsRef<Path>,
    rows: &[ProfileRow],
    title: &str,
) -> Result<()> {
    let path = path.as_ref();
    register_plot_fonts()?;
    let plottable = |v: f64| v.is_finite() && v > 0.0;
    let taus: Vec<f64> = rows
        .iter()
        .map(|r| r.tau)
        .filter(|t| t.is_finite())
        .collect();
    let values: Vec<f64> = rows
        .iter()
        .filter(|r| r.tau.is_finite())
        .flat_map(|r| [r.solved, r.pn_exact, r.cda, r.grosjean])
        .filter(|v| plottable(*v))
        .collect();
    if taus.is_empty() || values.is_empty() {
        bail!(
            "profile plot {}: no finite positive values to plot",
            path.display()
        );
    }
    let (mut t0, mut t1) = min_max(&taus);
    if t1 <= t0 {
        t0 -= 0.5;
        t1 += 0.5;
    }
    let (v0, v1) = min_max(&values);
    // Pad the log axis by a quarter decade each side.
    let (y0, y1) = (v0 / 10f64.powf(0.25), v1 * 10f64.powf(0.25));

    let draw_err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let root = white_canvas(path, (1000, 700))?;
    let mut chart = framed_chart(&root, title, 28)
        .build_cartesian_2d(t0..t1, (y0..y1).log_scale())
        .map_err(|e| draw_err(&e))?;
    chart
        .configure_mesh()
        .x_desc("τ = σ_t r")
        .y_desc("4πφ / σ_t²")
        .axis_desc_style(("sans-serif", 22))
        .label_style(("sans-serif", 18))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| draw_err(&e))?;

    let green = RGBColor(0, 140, 60);
    let series: [(&str, RGBColor, Column); 3] = [
        ("P_N exact", BLACK, |r| r.pn_exact),
        ("CDA", RED, |r| r.cda),
        ("Grosjean", green, |r| r.grosjean),
    ];
    for (name, color, get) in series {
        let style = ShapeStyle::from(&color).stroke_width(2);
        let mut labelled = false;
        for segment in positive_segments(rows, get) {
            let s = chart
                .draw_series(LineSeries::new(segment, style))
                .map_err(|e| draw_err(&e))?;
            if !labelled {
                s.label(name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], style));
                labelled = true;
            }
        }
    }
    let blue = RGBColor(30, 90, 220);
    let marker = ShapeStyle::from(&blue).filled();
    let solved: Vec<(f64, f64)> = positive_segments(rows, |r| r.solved)
        .into_iter()
        .flatten()
        .collect();
    if !solved.is_empty() {
        chart
            .draw_series(solved.iter().map(|p| Circle::new(*p, 3, marker)))
            .map_err(|e| draw_err(&e))?
            .label("solved (discrete)")
            .legend(move |(x, y)| Circle::new((x + 12, y), 4, marker));
    }
    finish_chart(&mut chart, &root, path, 20, SeriesLabelPosition::UpperRight)
}

/// Picks one column of a [`ProfileRow`].
type Column = fn(&ProfileRow) -> f64;

/// Smallest and largest of a non-empty slice.
fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        })
}

/// Splits the points (τ, get(row)) into runs of finite positive values (a log axis cannot show
/// the others), so lines break instead of jumping across gaps.
fn positive_segments(rows: &[ProfileRow], get: Column) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut current = Vec::new();
    for r in rows {
        let v = get(r);
        if r.tau.is_finite() && v.is_finite() && v > 0.0 {
            current.push((r.tau, v));
        } else if !current.is_empty() {
            out.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        out.push(current);
    }
    out
}
