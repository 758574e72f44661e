//! The race's plots: relative RMSE against wall seconds (log–log, one curve per method
//! family, each point labelled with its setting, the reference's own noise as a dashed
//! line), and the ablation's bias against the P_N order.

use anyhow::{ensure, Result};
use plotters::prelude::*;
use pn_formats::plot::{draw_error, finish_chart, framed_chart, white_canvas};
use std::path::Path;

/// One curve: its name and (seconds, error, label) points in time order.
#[derive(Clone, Debug)]
pub struct Curve {
    /// Legend text.
    pub name: String,
    /// Points.
    pub points: Vec<(f64, f64, String)>,
    /// Mitsuba curves are drawn dashed-grey/black, pn curves in colour.
    pub mitsuba: bool,
}

/// Line colours of the pn curves and of the ablation's scenes, in order.
const PALETTE: [RGBColor; 7] = [
    RGBColor(230, 120, 0),
    RGBColor(30, 90, 220),
    RGBColor(0, 150, 70),
    RGBColor(200, 30, 60),
    RGBColor(150, 60, 200),
    RGBColor(0, 170, 170),
    RGBColor(180, 140, 0),
];

/// Draws `curves` into `path` (PNG) with the title and the reference-noise line.
pub fn draw(path: &Path, title: &str, curves: &[Curve], ref_noise: f64) -> Result<()> {
    crate::plot::fonts()?;
    let ok = |v: f64| v.is_finite() && v > 0.0;
    let pts: Vec<(f64, f64)> = curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| (p.0, p.1)))
        .filter(|p| ok(p.0) && ok(p.1))
        .collect();
    ensure!(!pts.is_empty(), "nothing to plot");
    let (t0, t1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (mut e0, e1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    if ok(ref_noise) {
        e0 = e0.min(ref_noise);
    }
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let root = white_canvas(path, (1100, 780))?;
    let mut chart = framed_chart(&root, title, 24)
        .build_cartesian_2d(
            (t0 / 1.5..t1 * 1.5).log_scale(),
            (e0 / 1.4..e1 * 1.4).log_scale(),
        )
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("wall seconds, whole command (log)")
        .y_desc("relative RMSE against the reference (log)")
        .axis_desc_style(("sans-serif", 20))
        .label_style(("sans-serif", 16))
        .x_label_formatter(&|v| log_tick_label(*v))
        .y_label_formatter(&|v| log_tick_label(*v))
        .draw()
        .map_err(|e| err(&e))?;
    if ok(ref_noise) {
        let style = ShapeStyle::from(&RGBColor(120, 120, 120)).stroke_width(1);
        chart
            .draw_series(DashedLineSeries::new(
                vec![(t0 / 1.5, ref_noise), (t1 * 1.5, ref_noise)],
                6,
                4,
                style,
            ))
            .map_err(|e| err(&e))?
            .label(format!("reference noise {ref_noise:.4}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], style));
    }
    let mitsuba_colors = [BLACK, RGBColor(130, 130, 130)];
    let (mut mi, mut pi) = (0, 0);
    for c in curves {
        let color = if c.mitsuba {
            mi += 1;
            mitsuba_colors[(mi - 1) % mitsuba_colors.len()]
        } else {
            pi += 1;
            PALETTE[(pi - 1) % PALETTE.len()]
        };
        let p: Vec<(f64, f64, String)> = c
            .points
            .iter()
            .filter(|p| ok(p.0) && ok(p.1))
            .cloned()
            .collect();
        if p.is_empty() {
            continue;
        }
        let line = ShapeStyle::from(&color).stroke_width(2);
        let marker = ShapeStyle::from(&color).filled();
        chart
            .draw_series(LineSeries::new(p.iter().map(|q| (q.0, q.1)), line))
            .map_err(|e| err(&e))?
            .label(c.name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], line));
        if c.mitsuba {
            chart
                .draw_series(p.iter().map(|q| TriangleMarker::new((q.0, q.1), 5, marker)))
                .map_err(|e| err(&e))?;
        } else {
            chart
                .draw_series(p.iter().map(|q| Circle::new((q.0, q.1), 4, marker)))
                .map_err(|e| err(&e))?;
        }
        let font = ("sans-serif", 13).into_font().color(&color);
        chart
            .draw_series(
                p.iter()
                    .map(|q| Text::new(q.2.clone(), (q.0 * 1.04, q.1 * 1.03), font.clone())),
            )
            .map_err(|e| err(&e))?;
    }
    finish_chart(&mut chart, &root, path, 16, SeriesLabelPosition::UpperRight)
}

/// One scene's points of the ablation's order group: (P_N order, relative bias in %).
#[derive(Clone, Debug, PartialEq)]
pub struct OrderSeries {
    /// The scene.
    pub scene: String,
    /// (order, bias %), by order.
    pub points: Vec<(usize, f64)>,
}

/// The ablation's bias against the P_N order (`bias_vs_order.png`): one colour per scene,
/// odd orders as circles on solid lines, even orders as triangles on dashed lines, and the
/// zero line.
pub fn draw_bias_vs_order(path: &Path, series: &[OrderSeries]) -> Result<()> {
    crate::plot::fonts()?;
    let pts: Vec<(usize, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|p| p.1.is_finite())
        .collect();
    ensure!(!pts.is_empty(), "nothing to plot");
    let (n0, n1) = pts
        .iter()
        .fold((usize::MAX, 0), |(a, b), p| (a.min(p.0), b.max(p.0)));
    // The y range follows the odd orders when there are any: the even orders can be off by
    // a hundred percent and would flatten the odd ones' convergence; those beyond the range
    // are drawn at its edge with their value written next to them.
    let odd_only = pts.iter().any(|p| p.0 % 2 == 1);
    let (b0, b1) = pts
        .iter()
        .filter(|p| !odd_only || p.0 % 2 == 1)
        .fold((0.0f64, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let pad = 0.08 * (b1 - b0).max(1.0);
    let (y0, y1) = (b0 - pad, b1 + pad);
    let clip = |v: f64| v.clamp(y0 + 0.25 * pad, y1 - 0.25 * pad);
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    let root = white_canvas(path, (1000, 700))?;
    let x_range = (n0 as f64 - 0.5)..(n1 as f64 + 0.5);
    let mut chart = framed_chart(
        &root,
        "ablation: bias against Mitsuba by P_N order (odd: circles, solid; even: triangles, dashed)",
        22,
    )
    .build_cartesian_2d(x_range.clone(), y0..y1)
    .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("P_N order")
        .y_desc("relative bias of the image mean (%)")
        .axis_desc_style(("sans-serif", 20))
        .label_style(("sans-serif", 16))
        .x_labels(n1.saturating_sub(n0) + 2)
        .x_label_formatter(&|v| {
            if (v - v.round()).abs() < 1e-6 && *v >= 0.0 {
                format!("{}", v.round() as usize)
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| format!("{v:.1}"))
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .draw_series(LineSeries::new(
            vec![(x_range.start, 0.0), (x_range.end, 0.0)],
            ShapeStyle::from(&BLACK).stroke_width(1),
        ))
        .map_err(|e| err(&e))?;
    for (k, s) in series.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let line = ShapeStyle::from(&color).stroke_width(2);
        let marker = ShapeStyle::from(&color).filled();
        let parity = |odd: bool| -> Vec<(f64, f64)> {
            s.points
                .iter()
                .filter(|p| (p.0 % 2 == 1) == odd && p.1.is_finite())
                .map(|p| (p.0 as f64, p.1))
                .collect()
        };
        let (odd, even_raw) = (parity(true), parity(false));
        let off_scale: Vec<(f64, f64)> = even_raw
            .iter()
            .copied()
            .filter(|q| clip(q.1) != q.1)
            .collect();
        let even: Vec<(f64, f64)> = even_raw.iter().map(|q| (q.0, clip(q.1))).collect();
        let mut labelled = false;
        if !odd.is_empty() {
            chart
                .draw_series(LineSeries::new(odd.clone(), line))
                .map_err(|e| err(&e))?
                .label(s.scene.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], line));
            labelled = true;
            chart
                .draw_series(odd.iter().map(|&q| Circle::new(q, 5, marker)))
                .map_err(|e| err(&e))?;
        }
        if !even.is_empty() {
            let dashed = chart
                .draw_series(DashedLineSeries::new(even.clone(), 8, 5, line))
                .map_err(|e| err(&e))?;
            if !labelled {
                dashed
                    .label(s.scene.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], line));
            }
            chart
                .draw_series(even.iter().map(|&q| TriangleMarker::new(q, 6, marker)))
                .map_err(|e| err(&e))?;
            let font = ("sans-serif", 15).into_font().color(&color);
            chart
                .draw_series(off_scale.iter().enumerate().map(|(i, q)| {
                    let label = format!("{}: {:+.0} % (off scale)", s.scene, q.1);
                    // Stacked away from the edge the point sits on, one row per scene.
                    let inward = if q.1 > y1 { -1.0 } else { 1.0 };
                    let y = clip(q.1) + inward * (i + k) as f64 * 0.05 * (y1 - y0);
                    Text::new(label, (q.0 + 0.08, y), font.clone())
                }))
                .map_err(|e| err(&e))?;
        }
    }
    finish_chart(&mut chart, &root, path, 16, SeriesLabelPosition::LowerRight)
}

/// The label of a tick on a log axis: 1, 2 and 5 times a power of ten get their value
/// (`0.05`, `2`, `10`), the ticks between them none, so that labels never run together
/// where plotters puts nine ticks into one decade.
fn log_tick_label(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return String::new();
    }
    let exp = v.log10().floor();
    let mantissa = v / 10f64.powf(exp);
    let nice = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .any(|m| (mantissa - m).abs() < 1e-6 * m);
    if !nice {
        return String::new();
    }
    let digits = (-exp).max(0.0) as usize;
    format!("{v:.digits$}")
}

#[cfg(test)]
mod tick_tests {
    use super::log_tick_label;

    #[test]
    fn only_one_two_five_ticks_are_labelled() {
        assert_eq!(log_tick_label(0.05), "0.05");
        assert_eq!(log_tick_label(2.0), "2");
        assert_eq!(log_tick_label(10.0), "10");
        assert_eq!(log_tick_label(0.1), "0.1");
        assert_eq!(log_tick_label(7.0), "");
        assert_eq!(log_tick_label(0.3), "");
        assert_eq!(log_tick_label(0.0), "");
    }
}
