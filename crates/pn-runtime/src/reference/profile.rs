//! The point-source profile outputs (docs/pointsource.md): `profile.csv` and `profile.png`, the discrete
//! solution along a ray from the source against the semi-analytic P_N solution, CDA and
//! Grosjean (the plot a reader of the paper knows as its Figure 9).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::OnceLock;

use anyhow::{anyhow, bail, Context, Result};
use plotters::prelude::*;

use super::closed_forms::{cda_point_source, grosjean};
use super::pointsource::PointSourceModes;
use crate::plot::{draw_error, finish_chart, framed_chart, white_canvas};

/// One sample of the profile: normalised fluences `4πφ/σ_t²` at optical distance `tau`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileRow {
    /// Optical distance τ = σ_t r from the source.
    pub tau: f64,
    /// The discrete (solved) value.
    pub solved: f64,
    /// The semi-analytic P_N value ([`crate::reference::PointSourceModes`]).
    pub pn_exact: f64,
    /// Classical diffusion ([`crate::reference::cda_point_source`]).
    pub cda: f64,
    /// Grosjean's approximation of transport ([`crate::reference::grosjean`]).
    pub grosjean: f64,
}

impl ProfileRow {
    /// A row for a point source at optical distance `tau`: the discrete value `solved` beside
    /// the semi-analytic `modes` (smooth part), CDA and Grosjean for the same medium
    /// (Grosjean is for isotropic scattering: it uses the albedo and ignores g).
    pub fn point_source(tau: f64, solved: f64, modes: &PointSourceModes) -> Self {
        Self {
            tau,
            solved,
            pn_exact: modes.fluence(tau),
            cda: cda_point_source(tau, modes.albedo, modes.g),
            grosjean: grosjean(tau, modes.albedo),
        }
    }
}

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
