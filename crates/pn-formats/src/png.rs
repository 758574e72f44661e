//! `fluence.png`: a log10 colour map of a 2D slice with a colour bar; values ≤ 0 are
//! drawn in magenta (like the negative-value marking of the StaRMAP plots).

use plotters::prelude::*;
use std::path::Path;

/// A 2D slice to plot: `values[i·ny + j]` at cell (i, j) of an `nx × ny` grid over the box.
pub struct Slice<'a> {
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Values, x slowest.
    pub values: &'a [f64],
    /// Lower corner (x, y).
    pub min: [f64; 2],
    /// Upper corner (x, y).
    pub max: [f64; 2],
    /// Title.
    pub title: String,
}

/// How many decades below the maximum the colour scale reaches at most.
const DECADES: f64 = 8.0;

/// Viridis anchor colours, interpolated linearly.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 44, 122),
    (59, 81, 139),
    (44, 113, 142),
    (33, 144, 141),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

fn colour(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let i = (t.floor() as usize).min(VIRIDIS.len() - 2);
    let f = t - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |x: u8, y: u8| (x as f64 + f * (y as f64 - x as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

const NEGATIVE: RGBColor = RGBColor(255, 0, 255);

/// Writes the colour map to `path`.
pub fn write_png(path: &Path, slice: &Slice) -> anyhow::Result<()> {
    let positive = slice
        .values
        .iter()
        .copied()
        .filter(|v| *v > 0.0 && v.is_finite());
    let hi = positive.clone().fold(f64::NEG_INFINITY, f64::max);
    let lo = positive.fold(f64::INFINITY, f64::min);
    let (lo, hi) = if hi.is_finite() {
        let hi_l = hi.log10();
        let lo_l = lo.log10().max(hi_l - DECADES);
        if hi_l - lo_l < 1e-9 {
            (lo_l - 0.5, hi_l + 0.5)
        } else {
            (lo_l, hi_l)
        }
    } else {
        (-1.0, 0.0)
    };
    // Fonts are embedded (plotters' ab_glyph backend has no system fonts); without them the
    // picture is drawn unlabelled.
    let labels = crate::plot::register_plot_fonts().is_ok();
    match draw(path, slice, lo, hi, labels) {
        Ok(()) => Ok(()),
        Err(_) => draw(path, slice, lo, hi, false),
    }
}

fn draw(path: &Path, s: &Slice, lo: f64, hi: f64, labels: bool) -> anyhow::Result<()> {
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("cannot draw {}: {e}", path.display());
    let aspect = (s.max[1] - s.min[1]) / (s.max[0] - s.min[0]);
    let w_main = 640u32;
    let h = ((w_main as f64 - 70.0) * aspect + 90.0).clamp(200.0, 1400.0) as u32;
    let root = BitMapBackend::new(path, (w_main + 150, h)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (left, right) = root.split_horizontally(w_main);
    let mut cb = ChartBuilder::on(&left);
    cb.margin(12);
    if labels {
        cb.caption(&s.title, ("sans-serif", 18))
            .x_label_area_size(35)
            .y_label_area_size(50);
    }
    let mut chart = cb
        .build_cartesian_2d(s.min[0]..s.max[0], s.min[1]..s.max[1])
        .map_err(|e| err(&e))?;
    if labels {
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x")
            .y_desc("y")
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 16))
            .draw()
            .map_err(|e| err(&e))?;
    }
    let hx = (s.max[0] - s.min[0]) / s.nx as f64;
    let hy = (s.max[1] - s.min[1]) / s.ny as f64;
    chart
        .draw_series(
            (0..s.nx)
                .flat_map(|i| (0..s.ny).map(move |j| (i, j)))
                .map(|(i, j)| {
                    let v = s.values[i * s.ny + j];
                    let c = if v > 0.0 && v.is_finite() {
                        colour((v.log10() - lo) / (hi - lo))
                    } else {
                        NEGATIVE
                    };
                    let x0 = s.min[0] + i as f64 * hx;
                    let y0 = s.min[1] + j as f64 * hy;
                    Rectangle::new([(x0, y0), (x0 + hx, y0 + hy)], c.filled())
                }),
        )
        .map_err(|e| err(&e))?;

    let mut bb = ChartBuilder::on(&right);
    bb.margin(12).margin_top(40);
    if labels {
        bb.y_label_area_size(75).x_label_area_size(35);
    }
    let mut bar = bb
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(|e| err(&e))?;
    if labels {
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc("log10 L_0^0   (magenta: value <= 0)")
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 16))
            .draw()
            .map_err(|e| err(&e))?;
    }
    let steps = 256;
    bar.draw_series((0..steps).map(|k| {
        let a = lo + (hi - lo) * k as f64 / steps as f64;
        let b = lo + (hi - lo) * (k + 1) as f64 / steps as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            colour((k as f64 + 0.5) / steps as f64).filled(),
        )
    }))
    .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_map_ends() {
        assert_eq!(colour(0.0), RGBColor(68, 1, 84));
        assert_eq!(colour(1.0), RGBColor(253, 231, 37));
    }
}
