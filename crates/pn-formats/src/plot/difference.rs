//! `difference.png` of `pn compare`: the false-colour map of a signed difference `a − b`
//! with a colour bar. A diverging blue–white–red scale, symmetric about zero up to the 99th
//! percentile of |a−b| (so that a few firefly pixels do not wash the map out; pixels beyond
//! it are drawn at full saturation).

use super::{draw_error, register_plot_fonts};
use anyhow::ensure;
use plotters::prelude::*;
use std::path::Path;

/// Blue (−1) – white (0) – red (+1).
fn diverging(t: f64) -> RGBColor {
    let t = t.clamp(-1.0, 1.0);
    let (lo, hi) = ((33.0, 102.0, 172.0), (178.0, 24.0, 43.0));
    let (c, s) = if t < 0.0 { (lo, -t) } else { (hi, t) };
    let mix = |x: f64| (255.0 + s * (x - 255.0)).round() as u8;
    RGBColor(mix(c.0), mix(c.1), mix(c.2))
}

/// The symmetric colour range: the 99th percentile of |a−b| (the maximum for tiny images),
/// or 1 when the images are equal.
fn colour_range(diff: &[f64]) -> f64 {
    let mut abs: Vec<f64> = diff.iter().map(|d| d.abs()).collect();
    abs.sort_by(f64::total_cmp);
    let k = ((abs.len() as f64 * 0.99).ceil() as usize).clamp(1, abs.len()) - 1;
    let r = abs.get(k).copied().unwrap_or(0.0);
    if r > 0.0 {
        r
    } else {
        abs.last().copied().filter(|m| *m > 0.0).unwrap_or(1.0)
    }
}

/// Writes the false-colour map of the difference `diff` (`a − b`, row-major, row 0 at the
/// top, `diff[y·width + x]`) with a colour bar and `title` to `path` (PNG). `diff` must hold
/// `width·height` finite values, at least one.
pub fn write_difference_png(
    path: &Path,
    width: usize,
    height: usize,
    diff: &[f64],
    title: &str,
) -> anyhow::Result<()> {
    ensure!(
        !diff.is_empty() && diff.len() == width * height,
        "difference image of {width}×{height} pixels with {} values",
        diff.len()
    );
    ensure!(
        diff.iter().all(|d| d.is_finite()),
        "difference image with a non-finite value"
    );
    let range = colour_range(diff);
    let labels = register_plot_fonts().is_ok();
    match draw(path, width, height, diff, range, title, labels) {
        Ok(()) => Ok(()),
        Err(_) => draw(path, width, height, diff, range, title, false),
    }
}

fn draw(
    path: &Path,
    w: usize,
    h: usize,
    diff: &[f64],
    range: f64,
    title: &str,
    labels: bool,
) -> anyhow::Result<()> {
    let err = |e: &dyn std::fmt::Display| draw_error(path, e);
    // Integer upscaling so that small images stay readable; at most ~800 px wide.
    let scale = (800 / w.max(1)).clamp(1, 8) as u32;
    let (iw, ih) = (w as u32 * scale, h as u32 * scale);
    let top = if labels { 40 } else { 10 };
    let bar_w = 150;
    let root =
        BitMapBackend::new(path, (iw + 20 + bar_w, (ih + top + 20).max(260))).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    if labels {
        root.draw_text(title, &("sans-serif", 18).into_text_style(&root), (10, 10))
            .map_err(|e| err(&e))?;
    }
    let img = root.margin(top, 10, 10, 10 + bar_w);
    for y in 0..h {
        for x in 0..w {
            let c = diverging(diff[y * w + x] / range);
            let (x0, y0) = ((x as u32 * scale) as i32, (y as u32 * scale) as i32);
            img.draw(&Rectangle::new(
                [(x0, y0), (x0 + scale as i32, y0 + scale as i32)],
                c.filled(),
            ))
            .map_err(|e| err(&e))?;
        }
    }
    let (_, right) = root.split_horizontally(iw + 20);
    let mut bb = ChartBuilder::on(&right);
    bb.margin(10).margin_top(top as i32);
    if labels {
        bb.y_label_area_size(85);
    }
    let mut bar = bb
        .build_cartesian_2d(0.0..1.0, -range..range)
        .map_err(|e| err(&e))?;
    if labels {
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc("a − b")
            .y_label_formatter(&|v| format!("{v:.2e}"))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
    }
    let steps = 128;
    bar.draw_series((0..steps).map(|k| {
        let lo = -range + 2.0 * range * k as f64 / steps as f64;
        let hi = -range + 2.0 * range * (k + 1) as f64 / steps as f64;
        Rectangle::new(
            [(0.0, lo), (1.0, hi)],
            diverging((lo + hi) / (2.0 * range)).filled(),
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
    fn difference_image_has_the_right_colours() {
        let dir = std::env::temp_dir().join(format!("pn-difference-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("d.png");
        // Left half brighter in a (red), right half darker (blue).
        let (w, h) = (20, 10);
        let diff: Vec<f64> = (0..w * h)
            .map(|i| if i % w < 10 { 0.2 } else { -0.2 })
            .collect();
        write_difference_png(&path, w, h, &diff, "test").unwrap();
        let png = image::open(&path).unwrap().to_rgb8();
        assert!(png.width() >= 200);
        // Saturated red pixels (a > b) lie left of saturated blue ones (a < b).
        let xs = |want: [u8; 3]| -> Vec<u32> {
            png.enumerate_pixels()
                .filter(|(_, _, p)| p.0 == want)
                .map(|(x, _, _)| x)
                .collect()
        };
        let (red, blue) = (xs([178, 24, 43]), xs([33, 102, 172]));
        assert!(red.len() > 1000 && blue.len() > 1000);
        // Pixel scale 8 (800/20, capped): 10 image pixels = 80 bitmap pixels per half.
        assert!(red.iter().max().unwrap() < blue.iter().min().unwrap());
        assert!(blue.iter().max().unwrap() - red.iter().min().unwrap() >= 159);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_wrong_size_or_a_nan_is_an_error() {
        let path = Path::new("never-written.png");
        assert!(write_difference_png(path, 3, 2, &[0.0; 5], "x").is_err());
        assert!(write_difference_png(path, 0, 0, &[], "x").is_err());
        assert!(write_difference_png(path, 1, 1, &[f64::NAN], "x").is_err());
        assert!(!path.exists());
    }

    #[test]
    fn colour_range_ignores_a_firefly() {
        let mut d = vec![0.1; 1000];
        d[3] = 100.0;
        assert!((colour_range(&d) - 0.1).abs() < 1e-15);
        assert_eq!(colour_range(&[0.0, 0.0]), 1.0);
    }
}
