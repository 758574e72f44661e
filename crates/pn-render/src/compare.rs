//! Image comparison (`pn compare`): error metrics between a test image `a` and a
//! reference `b` (e.g. ours against Mitsuba's), and a false-colour difference image.
//!
//! Metrics, over all N pixels of single-channel (grey) images, with
//! `ε = 10⁻² · mean(b)²` so that pixels where the reference is (nearly) black do not dominate:
//!
//! * `rmse` = √(Σ (a−b)² / N)
//! * `rel_mse` = Σ (a−b)² / (b² + ε) / N — relative MSE, the usual rendering metric
//! * `mean_rel_error` = Σ |a−b| / √(b² + ε) / N — mean relative error
//! * `rel_bias` = (mean(a) − mean(b)) / mean(b) — relative difference of the image means
//!   (a signed, noise-averaging check of the overall level)
//! * `max_abs` = max |a−b|
//!
//! The difference image maps `a − b` with a diverging blue–white–red scale, symmetric about
//! zero up to the 99th percentile of |a−b| (so that a few firefly pixels do not wash the map
//! out; pixels beyond it are drawn at full saturation), with a colour bar.

use anyhow::{ensure, Context};
use plotters::prelude::*;
use serde::Serialize;
use std::path::Path;

/// A single-channel image, row-major (row 0 at the top), `data[y·width + x]`.
#[derive(Clone, Debug, PartialEq)]
pub struct GrayImage {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Values, `width·height`.
    pub data: Vec<f64>,
}

/// The comparison metrics (see the module docs for the definitions).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Metrics {
    /// Number of pixels.
    pub pixels: usize,
    /// Root-mean-square error.
    pub rmse: f64,
    /// Relative mean-square error, Σ (a−b)²/(b²+ε) / N.
    pub rel_mse: f64,
    /// Mean relative error, Σ |a−b|/√(b²+ε) / N.
    pub mean_rel_error: f64,
    /// (mean(a) − mean(b)) / mean(b).
    pub rel_bias: f64,
    /// Largest absolute difference.
    pub max_abs: f64,
    /// Mean of `a`.
    pub mean_a: f64,
    /// Mean of `b`.
    pub mean_b: f64,
    /// The regulariser ε = 10⁻²·mean(b)².
    pub epsilon: f64,
}

/// Reads an EXR as grey (the mean of its colour channels; ours and Mitsuba's are equal),
/// with [`pn_formats::read_exr_gray`].
pub fn read_gray(path: &Path) -> anyhow::Result<GrayImage> {
    let (width, height, data) = pn_formats::read_exr_gray(path)?;
    Ok(GrayImage {
        width,
        height,
        data: data.into_iter().map(f64::from).collect(),
    })
}

/// Checks that `a` and `b` are non-empty, of the same size and with finite pixels; `names`
/// name them in the error ("the first image has a non-finite value at pixel (x, y)").
pub fn check_pair(a: &GrayImage, b: &GrayImage, names: [&str; 2]) -> anyhow::Result<()> {
    ensure!(
        a.width == b.width && a.height == b.height,
        "images differ in size: {}×{} against {}×{}",
        a.width,
        a.height,
        b.width,
        b.height
    );
    let n = a.data.len();
    ensure!(
        n > 0 && n == b.data.len() && n == a.width * a.height,
        "empty or inconsistent image"
    );
    for (name, img) in names.into_iter().zip([a, b]) {
        if let Some(i) = img.data.iter().position(|v| !v.is_finite()) {
            anyhow::bail!(
                "the {name} image has a non-finite value at pixel ({}, {})",
                i % img.width,
                i / img.width
            );
        }
    }
    Ok(())
}

/// The metrics of `a` against the reference `b`. Different sizes, empty images or
/// non-finite pixels are errors ([`check_pair`]).
pub fn metrics(a: &GrayImage, b: &GrayImage) -> anyhow::Result<Metrics> {
    check_pair(a, b, ["first", "second"])?;
    let n = a.data.len();
    let nf = n as f64;
    let mean_a = a.data.iter().sum::<f64>() / nf;
    let mean_b = b.data.iter().sum::<f64>() / nf;
    let epsilon = 1e-2 * mean_b * mean_b;
    let (mut se, mut rse, mut re, mut max_abs) = (0.0, 0.0, 0.0, 0.0f64);
    for (x, y) in a.data.iter().zip(&b.data) {
        let d = x - y;
        let denom = y * y + epsilon;
        se += d * d;
        if denom > 0.0 {
            rse += d * d / denom;
            re += d.abs() / denom.sqrt();
        }
        max_abs = max_abs.max(d.abs());
    }
    Ok(Metrics {
        pixels: n,
        rmse: (se / nf).sqrt(),
        rel_mse: rse / nf,
        mean_rel_error: re / nf,
        rel_bias: if mean_b != 0.0 {
            (mean_a - mean_b) / mean_b
        } else {
            f64::NAN
        },
        max_abs,
        mean_a,
        mean_b,
        epsilon,
    })
}

impl std::fmt::Display for Metrics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "pixels          {}", self.pixels)?;
        writeln!(f, "rmse            {:.6e}", self.rmse)?;
        writeln!(f, "rel_mse         {:.6e}", self.rel_mse)?;
        writeln!(f, "mean_rel_error  {:.6e}", self.mean_rel_error)?;
        writeln!(f, "rel_bias        {:+.6e}", self.rel_bias)?;
        writeln!(f, "max_abs         {:.6e}", self.max_abs)?;
        write!(
            f,
            "mean a / b      {:.6e} / {:.6e}",
            self.mean_a, self.mean_b
        )
    }
}

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

/// Writes the false-colour map of `a − b` with a colour bar to `path` (PNG).
pub fn write_difference_png(
    path: &Path,
    a: &GrayImage,
    b: &GrayImage,
    title: &str,
) -> anyhow::Result<()> {
    metrics(a, b)?;
    let diff: Vec<f64> = a.data.iter().zip(&b.data).map(|(x, y)| x - y).collect();
    let range = colour_range(&diff);
    let labels = pn_formats::plot::register_plot_fonts().is_ok();
    match draw(path, a.width, a.height, &diff, range, title, labels) {
        Ok(()) => Ok(()),
        Err(_) => draw(path, a.width, a.height, &diff, range, title, false),
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
    let err = |e: &dyn std::fmt::Display| pn_formats::plot::draw_error(path, e);
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

/// Compares the images at `a` and `b` (the reference); with `out`, writes
/// `out/difference.png` and `out/metrics.json`.
pub fn compare_files(
    a: &Path,
    b: &Path,
    out: Option<&Path>,
) -> anyhow::Result<(Metrics, Option<Vec<ChannelMetrics>>)> {
    let (wa, ha, ca) = pn_formats::read_exr_rgb(a)?;
    let (wb, hb, cb) = pn_formats::read_exr_rgb(b)?;
    let grey = |width, height, c: &[Vec<f32>; 3]| GrayImage {
        width,
        height,
        data: pn_formats::channel_mean(c)
            .into_iter()
            .map(f64::from)
            .collect(),
    };
    let (ia, ib) = (grey(wa, ha, &ca), grey(wb, hb, &cb));
    let m = metrics(&ia, &ib)
        .with_context(|| format!("comparing {} with {}", a.display(), b.display()))?;
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let title = format!(
            "{} − {}   RMSE {:.3e}",
            a.file_name()
                .map_or(String::new(), |s| s.to_string_lossy().into()),
            b.file_name()
                .map_or(String::new(), |s| s.to_string_lossy().into()),
            m.rmse
        );
        write_difference_png(&dir.join("difference.png"), &ia, &ib, &title)?;
        let json = serde_json::to_string_pretty(&m)?;
        std::fs::write(dir.join("metrics.json"), json + "\n")
            .with_context(|| format!("cannot write {}", dir.join("metrics.json").display()))?;
    }
    Ok((m, channel_metrics(&ca, &cb)))
}

/// Error metrics of one colour channel ([`compare_files`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChannelMetrics {
    /// "R", "G" or "B".
    pub channel: String,
    /// (mean(a) − mean(b)) / mean(b) in this channel.
    pub rel_bias: f64,
    /// ‖a − b‖₂ / ‖b‖₂ over the channel's pixels.
    pub rel_rmse: f64,
    /// Root-mean-square error.
    pub rmse: f64,
    /// Mean of `a`.
    pub mean_a: f64,
    /// Mean of `b`.
    pub mean_b: f64,
}

/// Per-channel metrics of the channels `ca` against the reference's `cb` (of the same size,
/// checked by [`metrics`] before), or `None` when both are grey (equal R, G and B in every
/// pixel), where the metrics of the mean say everything.
fn channel_metrics(ca: &[Vec<f32>; 3], cb: &[Vec<f32>; 3]) -> Option<Vec<ChannelMetrics>> {
    let grey = |c: &[Vec<f32>; 3]| c[0] == c[1] && c[1] == c[2];
    if grey(ca) && grey(cb) {
        return None;
    }
    let out = (0..3)
        .map(|c| {
            let (x, y) = (&ca[c], &cb[c]);
            let n = x.len() as f64;
            let mean_a = x.iter().map(|v| *v as f64).sum::<f64>() / n;
            let mean_b = y.iter().map(|v| *v as f64).sum::<f64>() / n;
            let se: f64 = x
                .iter()
                .zip(y)
                .map(|(p, q)| (*p as f64 - *q as f64).powi(2))
                .sum();
            let norm_b: f64 = y.iter().map(|q| (*q as f64).powi(2)).sum();
            ChannelMetrics {
                channel: super::colour::CHANNELS[c].into(),
                rel_bias: (mean_a - mean_b) / mean_b,
                rel_rmse: (se / norm_b).sqrt(),
                rmse: (se / n).sqrt(),
                mean_a,
                mean_b,
            }
        })
        .collect();
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: usize, h: usize, f: impl Fn(usize, usize) -> f64) -> GrayImage {
        GrayImage {
            width: w,
            height: h,
            data: (0..w * h).map(|i| f(i % w, i / w)).collect(),
        }
    }

    #[test]
    fn metrics_match_hand_computed_values() {
        // b = 1 everywhere, a = 1 + 0.1·(±1): rmse 0.1, ε = 0.01, rel_mse = 0.01/1.01.
        let b = img(4, 2, |_, _| 1.0);
        let a = img(4, 2, |x, _| if x % 2 == 0 { 1.1 } else { 0.9 });
        let m = metrics(&a, &b).unwrap();
        assert!((m.rmse - 0.1).abs() < 1e-12);
        assert!((m.rel_mse - 0.01 / 1.01).abs() < 1e-12);
        assert!((m.mean_rel_error - 0.1 / 1.01f64.sqrt()).abs() < 1e-12);
        assert!(m.rel_bias.abs() < 1e-12);
        assert!((m.max_abs - 0.1).abs() < 1e-12);
        let a2 = img(4, 2, |_, _| 1.5);
        assert!((metrics(&a2, &b).unwrap().rel_bias - 0.5).abs() < 1e-12);
    }

    #[test]
    fn size_mismatch_and_nan_are_errors() {
        let a = img(4, 2, |_, _| 1.0);
        let b = img(2, 4, |_, _| 1.0);
        assert!(metrics(&a, &b)
            .unwrap_err()
            .to_string()
            .contains("differ in size"));
        let mut c = img(4, 2, |_, _| 1.0);
        c.data[5] = f64::NAN;
        assert!(metrics(&c, &a).unwrap_err().to_string().contains("(1, 1)"));
    }

    #[test]
    fn difference_image_has_the_right_colours() {
        let dir = std::env::temp_dir().join(format!("pn-compare-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("d.png");
        // Left half brighter in a (red), right half darker (blue).
        let b = img(20, 10, |_, _| 1.0);
        let a = img(20, 10, |x, _| if x < 10 { 1.2 } else { 0.8 });
        write_difference_png(&path, &a, &b, "test").unwrap();
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
    fn colour_range_ignores_a_firefly() {
        let mut d = vec![0.1; 1000];
        d[3] = 100.0;
        assert!((colour_range(&d) - 0.1).abs() < 1e-15);
        assert_eq!(colour_range(&[0.0, 0.0]), 1.0);
    }
}
