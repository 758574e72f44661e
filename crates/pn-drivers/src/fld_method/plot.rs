//! The FLD paper's Figure 5 for the `pointsource` scene: normalised fluence `4πφ/(P σ_t²)`
//! (P the source power) against τ = σ_t r along +x from the source cell, for the discrete
//! CDA and FLD with every limiter, beside the closed-form CDA Green's function, Grosjean's
//! approximation and the semi-analytic P_N solution (N = [`FIG5_PN_ORDER`]). Written as
//! `fld_profile.png` and `fld_profile.csv`.
//!
//! Only with `all_limiters` (`pn solve --fld-all-limiters`) are CDA and the limiters other
//! than the run's own solved, by the same route and settings, each starting from the run's
//! solution (the same answer, fewer iterations); otherwise the figure shows the run's own
//! limiter beside the closed forms, and a request costs one solve.

use anyhow::Result;
use plotters::prelude::*;
use pn_formats::plot::register_plot_fonts;
use pn_formats::plot::{draw_error, finish_chart, framed_chart, white_canvas};
use pn_runtime::fld::{FldProblem, Limiter};
use pn_runtime::reference::{cda_point_source, grosjean, pn_point_source};
use pn_runtime::scenes::{PointSourceParams, PointSourceShape};
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::Path;

use crate::fld_setup::{solve_fld_route, FldRun, FldSettings};
use pn_kernels::KernelChoice;

/// Order of the semi-analytic P_N reference in the plot.
pub const FIG5_PN_ORDER: usize = 5;

/// The limiters of the figure, CDA first.
const LIMITERS: [Limiter; 6] = [
    Limiter::Cda,
    Limiter::LevermorePomraning,
    Limiter::Sum,
    Limiter::Max,
    Limiter::Kershaw,
    Limiter::Larsen(2.0),
];

/// One discrete curve: its name and the normalised fluence per sample.
struct Curve {
    name: String,
    values: Vec<f64>,
}

/// Samples the run (and, with `all_limiters`, CDA and the other limiters, solved here)
/// along +x and writes the CSV and the PNG.
pub fn write_figure5(
    out: &Path,
    params: &PointSourceParams,
    fp: &FldProblem,
    settings: &FldSettings,
    kernel: &KernelChoice,
    run: &FldRun,
    all_limiters: bool,
) -> Result<()> {
    let PointSourceParams {
        sigma_t,
        albedo,
        g,
        source,
        ..
    } = *params;
    let grid = fp.grid;
    let h3 = grid.h.powi(3);
    let power: f64 = fp.source.iter().sum::<f64>() * h3;
    anyhow::ensure!(power > 0.0, "the point source has no power");
    // The source cell: index n/2 per axis (as in `pn_runtime::scenes`); samples along +x up
    // to the last interior cell.
    let c = grid.n.map(|m| m / 2);
    let samples: Vec<(f64, usize)> = (1..grid.n[0].saturating_sub(1 + c[0]))
        .map(|s| {
            (
                sigma_t * s as f64 * grid.h,
                grid.index(c[0] + s, c[1], c[2]),
            )
        })
        .collect();
    anyhow::ensure!(
        !samples.is_empty(),
        "the grid has no cells beyond the source"
    );
    let normalise = |phi: &[f64]| -> Vec<f64> {
        samples
            .iter()
            .map(|&(_, idx)| 4.0 * PI * phi[idx] / (power * sigma_t * sigma_t))
            .collect()
    };

    let mut curves = Vec::new();
    let own = [settings.params.limiter];
    let limiters: &[Limiter] = if all_limiters { &LIMITERS } else { &own };
    for &limiter in limiters {
        let name = if limiter == Limiter::Cda {
            "CDA (discrete)".to_string()
        } else {
            format!("FLD {limiter}")
        };
        let values = if limiter == settings.params.limiter {
            normalise(&run.solution.phi)
        } else {
            let mut s = settings.clone();
            s.params.limiter = limiter;
            let other = solve_fld_route(fp, &s, kernel, Some(&run.solution.phi))?;
            if !other.solution.converged {
                eprintln!(
                    "note: {name} for the profile did not converge (relative residual {:.2e})",
                    other.solution.final_residual()
                );
            }
            normalise(&other.solution.phi)
        };
        curves.push(Curve { name, values });
    }

    // References: point-source closed forms; a Gaussian source gets the Gaussian-smoothed
    // P_N and CDA, and no Grosjean (its e^{−τ}/τ² term is not a Yukawa mode).
    let s_tau = match source {
        PointSourceShape::Cell => 0.0,
        PointSourceShape::Gaussian(s) => sigma_t * s,
    };
    let pn = pn_point_source(FIG5_PN_ORDER, albedo, g);
    if let Err(e) = &pn {
        eprintln!("note: no P_{FIG5_PN_ORDER} reference in the FLD profile: {e:#}");
    }
    let taus: Vec<f64> = samples.iter().map(|s| s.0).collect();
    let reference = |f: &dyn Fn(f64) -> f64| -> Vec<f64> { taus.iter().map(|&t| f(t)).collect() };
    let pn_vals = match &pn {
        Ok(m) => reference(&|t| m.fluence_gaussian(t, s_tau)),
        Err(_) => vec![f64::NAN; taus.len()],
    };
    let cda_vals = if s_tau == 0.0 {
        reference(&|t| cda_point_source(t, albedo, g))
    } else {
        match pn_runtime::reference::PointSourceModes::cda(albedo, g) {
            Ok(m) => reference(&|t| m.fluence_gaussian(t, s_tau)),
            Err(_) => vec![f64::NAN; taus.len()],
        }
    };
    let grosjean_vals = if s_tau == 0.0 {
        reference(&|t| grosjean(t, albedo))
    } else {
        vec![f64::NAN; taus.len()]
    };
    let refs = [
        (format!("P_{FIG5_PN_ORDER} exact"), pn_vals),
        ("CDA (closed form)".to_string(), cda_vals),
        ("Grosjean".to_string(), grosjean_vals),
    ];

    // CSV.
    let mut csv = String::from("tau");
    for name in curves
        .iter()
        .map(|c| &c.name)
        .chain(refs.iter().map(|r| &r.0))
    {
        write!(csv, ",{}", column_name(name))?;
    }
    csv.push('\n');
    for (i, t) in taus.iter().enumerate() {
        write!(csv, "{t}")?;
        for v in curves
            .iter()
            .map(|c| c.values[i])
            .chain(refs.iter().map(|r| r.1[i]))
        {
            write!(csv, ",{v}")?;
        }
        csv.push('\n');
    }
    std::fs::write(out.join("fld_profile.csv"), csv)?;

    let title = format!(
        "Point source, FLD ({} route): albedo {albedo}, sigma_t {sigma_t}, {}^3 cells",
        settings.route.name(),
        grid.n[0]
    );
    draw(&out.join("fld_profile.png"), &title, &taus, &curves, &refs)
}

/// A CSV column name: lower case, spaces and parentheses to underscores.
fn column_name(name: &str) -> String {
    let s: String = name
        .to_ascii_lowercase()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    s.trim_matches('_').replace("__", "_")
}

/// Draws the log-scale plot: references as thick lines, discrete solutions as thin lines
/// with markers.
fn draw(
    path: &Path,
    title: &str,
    taus: &[f64],
    curves: &[Curve],
    refs: &[(String, Vec<f64>)],
) -> Result<()> {
    register_plot_fonts()?;
    let ok = |v: f64| v.is_finite() && v > 0.0;
    let values: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.values.iter())
        .chain(refs.iter().flat_map(|r| r.1.iter()))
        .copied()
        .filter(|v| ok(*v))
        .collect();
    anyhow::ensure!(!values.is_empty(), "no positive values to plot");
    let (v0, v1) = values
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
    let t0 = taus.iter().copied().fold(f64::INFINITY, f64::min);
    let mut t1 = taus.iter().copied().fold(0.0, f64::max);
    if t1 <= t0 {
        t1 = t0 + 1.0;
    }
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let root = white_canvas(path, (1100, 750))?;
    let mut chart = framed_chart(&root, title, 26)
        .build_cartesian_2d(
            0.0..t1 * 1.02,
            (v0 / 10f64.powf(0.25)..v1 * 10f64.powf(0.25)).log_scale(),
        )
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("τ = σ_t r")
        .y_desc("4πφ / (P σ_t²)")
        .axis_desc_style(("sans-serif", 22))
        .label_style(("sans-serif", 18))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| err(&e))?;
    let ref_colors = [BLACK, RGBColor(200, 0, 0), RGBColor(0, 140, 60)];
    for ((name, vals), color) in refs.iter().zip(ref_colors) {
        let pts: Vec<(f64, f64)> = taus
            .iter()
            .zip(vals)
            .filter(|(_, v)| ok(**v))
            .map(|(t, v)| (*t, *v))
            .collect();
        if pts.is_empty() {
            continue;
        }
        let style = ShapeStyle::from(&color).stroke_width(3);
        chart
            .draw_series(LineSeries::new(pts, style))
            .map_err(|e| err(&e))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], style));
    }
    let palette = [
        RGBColor(255, 120, 0),
        RGBColor(30, 90, 220),
        RGBColor(150, 60, 200),
        RGBColor(0, 170, 170),
        RGBColor(180, 140, 0),
        RGBColor(230, 50, 150),
    ];
    for (curve, color) in curves.iter().zip(palette) {
        let pts: Vec<(f64, f64)> = taus
            .iter()
            .zip(&curve.values)
            .filter(|(_, v)| ok(**v))
            .map(|(t, v)| (*t, *v))
            .collect();
        if pts.is_empty() {
            continue;
        }
        let style = ShapeStyle::from(&color).stroke_width(1);
        let marker = ShapeStyle::from(&color).filled();
        chart
            .draw_series(LineSeries::new(pts.clone(), style))
            .map_err(|e| err(&e))?;
        chart
            .draw_series(pts.iter().map(|p| Circle::new(*p, 3, marker)))
            .map_err(|e| err(&e))?
            .label(curve.name.as_str())
            .legend(move |(x, y)| Circle::new((x + 12, y), 4, marker));
    }
    finish_chart(&mut chart, &root, path, 18, SeriesLabelPosition::UpperRight)
}
