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
//! Pure computation: the metrics, the per-channel metrics of colour images and the signed
//! difference `a − b` ([`difference`]) that `pn_formats::plot::difference` draws; reading
//! the files, writing `metrics.json` and `difference.png` are the drivers'
//! (`pn_drivers::compare`).

use anyhow::ensure;
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

/// The grey image of three colour channels of `width × height` pixels: their mean
/// ([`pn_formats::channel_mean`]), as `f64`.
pub fn gray_of_channels(width: usize, height: usize, channels: &[Vec<f32>; 3]) -> GrayImage {
    GrayImage {
        width,
        height,
        data: pn_formats::channel_mean(channels)
            .into_iter()
            .map(f64::from)
            .collect(),
    }
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

/// The signed difference `a − b`, pixel by pixel (row-major as the images), after the
/// checks of [`metrics`] (same size, non-empty, finite).
pub fn difference(a: &GrayImage, b: &GrayImage) -> anyhow::Result<Vec<f64>> {
    check_pair(a, b, ["first", "second"])?;
    Ok(a.data.iter().zip(&b.data).map(|(x, y)| x - y).collect())
}

/// Error metrics of one colour channel ([`channel_metrics`]).
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
pub fn channel_metrics(ca: &[Vec<f32>; 3], cb: &[Vec<f32>; 3]) -> Option<Vec<ChannelMetrics>> {
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
    fn difference_is_a_minus_b_after_the_checks() {
        let b = img(3, 2, |x, _| x as f64);
        let a = img(3, 2, |_, y| y as f64);
        let d = difference(&a, &b).unwrap();
        assert_eq!(d, vec![0.0, -1.0, -2.0, 1.0, 0.0, -1.0]);
        assert!(difference(&a, &img(2, 3, |_, _| 0.0)).is_err());
    }

    #[test]
    fn grey_channels_have_no_channel_metrics() {
        let grey = [vec![1.0f32, 2.0], vec![1.0, 2.0], vec![1.0, 2.0]];
        assert!(channel_metrics(&grey, &grey).is_none());
        let g = gray_of_channels(2, 1, &[vec![1.0, 2.0], vec![2.0, 2.0], vec![3.0, 2.0]]);
        assert_eq!(g.data, vec![2.0, 2.0]);
        let c = channel_metrics(&[vec![2.0, 2.0], vec![1.0, 1.0], vec![1.0, 1.0]], &grey).unwrap();
        assert_eq!(c.len(), 3);
        assert!((c[0].rel_bias - 1.0 / 3.0).abs() < 1e-12);
    }
}
