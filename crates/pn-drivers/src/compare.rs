//! `pn compare a.exr b.exr`: error metrics of image `a` against the reference `b` and a
//! false-colour difference image. The metrics are `pn_render::compare`'s, the drawing
//! `pn_formats::plot::difference`'s; this module reads the images and writes the files.

use anyhow::Context;
use pn_render::compare::{
    channel_metrics, difference, gray_of_channels, metrics, ChannelMetrics, GrayImage, Metrics,
};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// What `pn compare` compares.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CompareRequest {
    /// The image to judge (EXR).
    pub a: PathBuf,
    /// The reference image (EXR), e.g. Mitsuba's.
    pub b: PathBuf,
    /// Folder for `difference.png` (a − b, diverging colours) and `metrics.json`.
    pub out: Option<PathBuf>,
    /// Print the metrics as JSON.
    pub json: bool,
}

/// The metrics, and per channel for colour images.
#[derive(Serialize)]
struct Output {
    #[serde(flatten)]
    metrics: Metrics,
    #[serde(skip_serializing_if = "Option::is_none")]
    channels: Option<Vec<ChannelMetrics>>,
}

/// Runs `pn compare`, printing the metrics to `stdout` (of the channel means, and per
/// channel when either image is coloured).
pub fn run(args: &CompareRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    let (metrics, channels) = compare_files(&args.a, &args.b, args.out.as_deref())?;
    let out = Output { metrics, channels };
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&out)?)?;
    } else {
        writeln!(stdout, "{} against {}", args.a.display(), args.b.display())?;
        writeln!(stdout, "{}", out.metrics)?;
        for c in out.channels.iter().flatten() {
            writeln!(
                stdout,
                "channel {}: rel_bias {:+.4}, rel_rmse {:.4}, rmse {:.4e}, mean {:.4e} / {:.4e}",
                c.channel, c.rel_bias, c.rel_rmse, c.rmse, c.mean_a, c.mean_b
            )?;
        }
    }
    if let Some(dir) = &args.out {
        writeln!(stdout, "wrote {}", dir.join("difference.png").display())?;
    }
    Ok(())
}

/// Compares the images at `a` and `b` (the reference; EXR, or what
/// [`pn_formats::read_exr_rgb`] reads): the metrics of their channel means and,
/// for colour images, per channel. With `out`, writes `out/difference.png`
/// ([`write_difference_png`]) and `out/metrics.json`.
pub fn compare_files(
    a: &Path,
    b: &Path,
    out: Option<&Path>,
) -> anyhow::Result<(Metrics, Option<Vec<ChannelMetrics>>)> {
    let (wa, ha, ca) = pn_formats::read_exr_rgb(a)?;
    let (wb, hb, cb) = pn_formats::read_exr_rgb(b)?;
    let (ia, ib) = (gray_of_channels(wa, ha, &ca), gray_of_channels(wb, hb, &cb));
    let m = metrics(&ia, &ib)
        .with_context(|| format!("comparing {} with {}", a.display(), b.display()))?;
    if let Some(dir) = out {
        pn_formats::files::create_dir_all(dir)?;
        let title = format!(
            "{} − {}   RMSE {:.3e}",
            a.file_name()
                .map_or(String::new(), |s| s.to_string_lossy().into()),
            b.file_name()
                .map_or(String::new(), |s| s.to_string_lossy().into()),
            m.rmse
        );
        write_difference_png(&dir.join("difference.png"), &ia, &ib, &title)?;
        pn_formats::write_atomic(&dir.join("metrics.json"), &m)?;
    }
    Ok((m, channel_metrics(&ca, &cb)))
}

/// Writes the false-colour map of `a − b` with a colour bar to `path` (PNG,
/// [`pn_formats::plot::write_difference_png`]); images of different sizes,
/// empty ones or non-finite pixels are errors ([`pn_render::compare::check_pair`]).
pub fn write_difference_png(
    path: &Path,
    a: &GrayImage,
    b: &GrayImage,
    title: &str,
) -> anyhow::Result<()> {
    let diff = difference(a, b)?;
    pn_formats::plot::write_difference_png(path, a.width, a.height, &diff, title)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compare_files_writes_the_metrics_and_the_difference() {
        let dir = std::env::temp_dir().join(format!("pn-drivers-compare-{}", std::process::id()));
        pn_formats::files::create_dir_all(&dir).unwrap();
        let (w, h) = (6, 4);
        let b: Vec<f32> = vec![1.0; w * h];
        let a: Vec<f32> = (0..w * h).map(|i| 1.0 + 0.1 * (i % 2) as f32).collect();
        let (pa, pb) = (dir.join("a.exr"), dir.join("b.exr"));
        pn_formats::write_exr_gray(&pa, w, h, &a).unwrap();
        pn_formats::write_exr_gray(&pb, w, h, &b).unwrap();
        let out = dir.join("out");
        let (m, channels) = compare_files(&pa, &pb, Some(&out)).unwrap();
        assert!(channels.is_none());
        assert!((m.mean_a - m.mean_b - 0.05).abs() < 1e-6);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap())
                .unwrap();
        assert_eq!(json["pixels"], 24);
        assert!(out.join("difference.png").is_file());
        std::fs::remove_dir_all(&dir).ok();
    }
}
